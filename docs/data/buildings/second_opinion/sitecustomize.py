"""Experiment switch for the deployed network (use with PYTHONPATH=<this folder>):
GPCNAV_EXP_SECOND=1, its check with ``CheckSettings(second_opinion=True)``: near walls, when
the walls network's command and its roll-out both fail, the crowd network's command and
roll-out are judged before the check steps in (rule.md)."""
import os, sys
if os.environ.get("GPCNAV_EXP_SECOND") == "1":
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig = C._nn_check
    def _nn_check(*a, **kw):
        s = _orig(*a, **kw)
        return replace(s, second_opinion=True) if s.rollouts else s
    C.REGISTRY["nn"] = C.Kind(C.REGISTRY["nn"].default_shield, _nn_check)
    print("GPCNAV_EXP_SECOND=1", file=sys.stderr)
