"""Experiment switch (not shipped): GPCNAV_EXP_ADAPT=1 installs adaptive.py's per-track
process noise in every obstacle filter (use with PYTHONPATH=<this folder>)."""
import os
if os.environ.get("GPCNAV_EXP_ADAPT"):
    import adaptive
    adaptive.install()
    import sys
    print("GPCNAV_EXP_ADAPT: the adaptive process noise is installed", file=sys.stderr)
