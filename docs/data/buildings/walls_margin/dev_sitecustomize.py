"""The first, blunt switches of the development runs (runs/dev-*), before the margins near walls
were settings: GPCNAV_EXP_CFG="clearance_margin_m=0.05,uncertainty_sigmas=1.0" overrides the
improved preset everywhere (no walls needed); GPCNAV_EXP_CHK="sigmas=1.0,margin_m=0.02[,search=True,
search_two_phase=True,search_near_walls=True]" the GPC's check settings everywhere. `small`: both
margins; `V1`: the planner's alone; `BW`: both and the search near walls. In the wall suites a wall
is always within reach, so `BW` there is the rule's BW (dev-corridor-s2-BWreal.json, run with
sitecustomize.py, has the same outcomes and fallbacks as dev-corridor-s2-BW.json)."""
import os, sys
cfg = os.environ.get("GPCNAV_EXP_CFG")
if cfg:
    from casadi_gpc import config as K
    kv = {}
    for part in cfg.split(","):
        k, v = part.split("=")
        kv[k] = float(v)
    K.PRESETS["improved"] = K.PRESETS["improved"].with_overrides(**kv)
    print("GPCNAV_EXP_CFG", kv, file=sys.stderr)
chk = os.environ.get("GPCNAV_EXP_CHK")
if chk:
    from dataclasses import replace
    from gpcnav import controllers as C
    kv = {k: (v == "True") if v in ("True", "False") else float(v) for k, v in (p.split("=") for p in chk.split(","))}
    _orig = C._gpc_check
    def _gpc_check(*a, **kw):
        return replace(_orig(*a, **kw), **kv)
    C.REGISTRY["gpc"] = C.Kind(C.REGISTRY["gpc"].default_shield, _gpc_check)
    print("GPCNAV_EXP_CHK", kv, file=sys.stderr)
