"""Experiment (GPCNAV_EXP_TRUST=seconds): the GPC's check trusts its plans for this long
instead of the default 3 s."""
import os
_v = os.environ.get("GPCNAV_EXP_TRUST")
if _v:
    import dataclasses
    from gpcnav import controllers as _C
    _orig = _C._gpc_check

    def _gpc_check(controller, config, mode):
        return dataclasses.replace(_orig(controller, config, mode), trust_planner_s=float(_v))

    _C._gpc_check = _gpc_check
    _C.REGISTRY["gpc"] = _C.Kind("on", _gpc_check)
