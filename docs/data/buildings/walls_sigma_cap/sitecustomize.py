"""Experiment switch (use with PYTHONPATH=<this folder>): GPCNAV_EXP_SIGCAP=0.1 gives the
`improved` preset PlannerConfig.walls_sigma_cap_m = 0.1 (C10 of rule.md): near walls the
planner's margin is inflated by the forecast's deviation capped at 0.10 m."""
import os, sys
cap = os.environ.get("GPCNAV_EXP_SIGCAP")
if cap:
    from casadi_gpc import config as K
    K.PRESETS["improved"] = K.PRESETS["improved"].with_overrides(walls_sigma_cap_m=float(cap))
    print(f"GPCNAV_EXP_SIGCAP={cap}", file=sys.stderr)
