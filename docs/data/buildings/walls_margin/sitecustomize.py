"""Experiment switch for the GPC near walls (use with PYTHONPATH=<this folder>):
GPCNAV_EXP_WALLS_MARGIN=B: the planner's margin near walls 0.05 m + 1 sigma
(PlannerConfig.walls_margin_m, walls_sigmas; in the open 0.15 m + 2 sigma) and its check's
0.02 m + 1 sigma (CheckSettings.walls_margin_m, walls_sigmas; in the open 0.05 m + 2 sigma);
GPCNAV_EXP_WALLS_MARGIN=BW: the same and the check's way out searched in two phases near walls
(CheckSettings.search_near_walls, ../walls_search/); GPCNAV_EXP_WALLS_MARGIN=BW5: BW with the
check's margin near walls 0.05 m + 1 sigma (its open constant kept). rule.md and rule2.md say
what was judged."""
import os, sys
mode = os.environ.get("GPCNAV_EXP_WALLS_MARGIN")
if mode in ("B", "BW", "BW5"):
    from dataclasses import replace
    from casadi_gpc import config as K
    from gpcnav import controllers as C
    K.PRESETS["improved"] = K.PRESETS["improved"].with_overrides(walls_margin_m=0.05, walls_sigmas=1.0)
    _orig = C._gpc_check
    extra = dict(search=True, search_two_phase=True, search_near_walls=True) if mode != "B" else {}
    check_margin = 0.05 if mode == "BW5" else 0.02
    def _gpc_check(*a, **kw):
        return replace(_orig(*a, **kw), walls_margin_m=check_margin, walls_sigmas=1.0, **extra)
    C.REGISTRY["gpc"] = C.Kind(C.REGISTRY["gpc"].default_shield, _gpc_check)
    print(f"GPCNAV_EXP_WALLS_MARGIN={mode}", file=sys.stderr)
if os.environ.get("GPCNAV_EXP_NN_WALLS_MARGIN") == "1":
    # the deployed network's check with the GPC's check margin near walls (0.05 m + 1 sigma)
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig_nn = C._nn_check
    def _nn_check(*a, **kw):
        return replace(_orig_nn(*a, **kw), walls_margin_m=0.05, walls_sigmas=1.0)
    C.REGISTRY["nn"] = C.Kind(C.REGISTRY["nn"].default_shield, _nn_check)
    print("GPCNAV_EXP_NN_WALLS_MARGIN=1", file=sys.stderr)
