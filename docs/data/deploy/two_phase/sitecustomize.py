"""Experiment switches (use with PYTHONPATH=<this folder>):
GPCNAV_EXP_TWO_PHASE=0 turns the deployed network's two-phase way out off (the check before it);
GPCNAV_EXP_TP_BASES=k and GPCNAV_EXP_TP_SWITCH=1.0,2.0 set its bases and switch times;
GPCNAV_EXP_GPC_TWO_PHASE=1 gives the GPC's check the searched way out in two phases."""
import os
import sys

if os.environ.get("GPCNAV_EXP_TWO_PHASE") == "0":
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig = C._nn_check

    def _nn_check(*a, **kw):
        return replace(_orig(*a, **kw), search_two_phase=False)

    C.REGISTRY["nn"] = C.Kind(C.REGISTRY["nn"].default_shield, _nn_check)
    print("GPCNAV_EXP_TWO_PHASE=0: the two-phase way out is off", file=sys.stderr)

if os.environ.get("GPCNAV_EXP_TP_BASES") or os.environ.get("GPCNAV_EXP_TP_SWITCH"):
    from casadi_gpc.safety import search as S
    if os.environ.get("GPCNAV_EXP_TP_BASES"):
        S.TWO_PHASE_BASES = int(os.environ["GPCNAV_EXP_TP_BASES"])
    if os.environ.get("GPCNAV_EXP_TP_SWITCH"):
        S.TWO_PHASE_SWITCH_S = tuple(float(x) for x in os.environ["GPCNAV_EXP_TP_SWITCH"].split(","))
    print(f"two-phase bases {S.TWO_PHASE_BASES}, switches {S.TWO_PHASE_SWITCH_S}", file=sys.stderr)

if os.environ.get("GPCNAV_EXP_GPC_TWO_PHASE"):
    # the GPC's check with the searched way out and its second phase (the planner's own
    # alternatives first, as shipped)
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig_gpc = C._gpc_check

    def _gpc_check(*a, **kw):
        return replace(_orig_gpc(*a, **kw), search=True, search_two_phase=True)

    C.REGISTRY["gpc"] = C.Kind(C.REGISTRY["gpc"].default_shield, _gpc_check)
    print("GPCNAV_EXP_GPC_TWO_PHASE: the GPC's check searches its way out, in two phases", file=sys.stderr)

if os.environ.get("GPCNAV_EXP_GPC_MANOEUVRE_TWO_PHASE"):
    # the GPC's check as shipped (no search; commands judged with the manoeuvres), but where no
    # manoeuvre keeps the margin its way out is the best manoeuvres continued with a second
    # target (the grid's) after 1 s: the network's second phase (WayOutSearch._two_phase) on
    # the manoeuvres instead of the searched set
    import numpy as np
    from casadi_gpc.safety import filter as F
    _orig_way = F.SafetyFilter._way_out

    def _way_out(self, state, obstacles, cmd):
        name, mw, mc = _orig_way(self, state, obstacles, cmd)
        if self.search_way_out or mc.safe:
            return name, mw, mc
        state = np.asarray(state, float)
        names, W = self.manoeuvres(state[3:5])
        got = self._two_phase(state, obstacles, W, self.clearances(state, W, obstacles),
                              (0.0, 0.0) if cmd is None else cmd, names)
        return (name, mw, mc) if got is None else got

    F.SafetyFilter._way_out = _way_out
    print("GPCNAV_EXP_GPC_MANOEUVRE_TWO_PHASE: the GPC's way out continues its manoeuvres in two phases",
          file=sys.stderr)
