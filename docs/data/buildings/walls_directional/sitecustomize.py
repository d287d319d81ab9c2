"""Experiment switch (use with PYTHONPATH=<this folder>): GPCNAV_EXP_DIRSIG=1 gives the
`improved` preset PlannerConfig.walls_directional_sigma = True (D of rule.md): near walls the
planner's margin from each mover is inflated by its forecast's deviation along the line from
it to the robot, not its worst."""
import os, sys
if os.environ.get("GPCNAV_EXP_DIRSIG") == "1":
    from casadi_gpc import config as K
    K.PRESETS["improved"] = K.PRESETS["improved"].with_overrides(walls_directional_sigma=True)
    print("GPCNAV_EXP_DIRSIG=1", file=sys.stderr)
