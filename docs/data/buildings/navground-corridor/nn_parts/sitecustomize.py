import os, sys
if os.environ.get("GPCNAV_EXP_NN_NOSEARCH") == "1":
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig = C._nn_check
    def _nn_check(*a, **kw):
        return replace(_orig(*a, **kw), search=False, search_two_phase=False)
    C.REGISTRY["nn"] = C.Kind(C.REGISTRY["nn"].default_shield, _nn_check)
    print("GPCNAV_EXP_NN_NOSEARCH=1", file=sys.stderr)
