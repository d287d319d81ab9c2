"""Experiment switches for the deployed network (use with PYTHONPATH=<this folder>):
GPCNAV_EXP_NN_NOSEARCH=1, its check without the searched way out (the runs of
../navground-corridor/nn_parts/); GPCNAV_EXP_NN_NOWALLNET=1, no walls network, the crowd
network answering near walls too (rule.md)."""
import os, sys
if os.environ.get("GPCNAV_EXP_NN_NOSEARCH") == "1":
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig = C._nn_check
    def _nn_check(*a, **kw):
        return replace(_orig(*a, **kw), search=False, search_two_phase=False)
    C.REGISTRY["nn"] = C.Kind(C.REGISTRY["nn"].default_shield, _nn_check)
    print("GPCNAV_EXP_NN_NOSEARCH=1", file=sys.stderr)
if os.environ.get("GPCNAV_EXP_NN_NOWALLNET") == "1":
    import nn_export.runtime.policy as P
    _orig_init = P.OnnxPolicy.__init__
    def __init__(self, *a, **kw):
        kw["walls_model"] = None
        _orig_init(self, *a, **kw)
    P.OnnxPolicy.__init__ = __init__
    print("GPCNAV_EXP_NN_NOWALLNET=1: no walls network (the crowd network answers near walls too)", file=sys.stderr)
