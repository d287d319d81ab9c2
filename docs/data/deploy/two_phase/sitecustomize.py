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
    # target (the grid's) after 1 s, as the network's search does with its held targets
    import numpy as np
    from casadi_gpc.safety import filter as F
    from casadi_gpc.safety import search as S
    from casadi_gpc.safety.ranking import best_unsafe_index
    _orig_way = F.SafetyFilter._way_out

    def _way_out(self, state, obstacles, cmd):
        name, mw, mc = _orig_way(self, state, obstacles, cmd)
        if self.search_way_out or mc.safe:
            return name, mw, mc
        self.counters["two_phase_searched"] += 1
        state = np.asarray(state, float)
        names, W = self.manoeuvres(state[3:5])
        found = self.clearances(state, W, obstacles)
        H, N = self.horizon, self.horizon * self.substeps
        cmin, kept, contact, fixed, drives = (np.array(found[k]) for k in (0, 4, 5, 6, 7))
        bases = []
        for _ in range(min(S.TWO_PHASE_BASES, len(cmin))):
            b = int(best_unsafe_index(cmin, kept, contact, fixed, drives, self._commit_chords))
            bases.append(b)
            cmin[b], kept[b], contact[b], fixed[b], drives[b] = -np.inf, -1, -1, -1, -1
        wish = (0.0, 0.0) if cmd is None else cmd
        best = None
        for b in bases:
            for s in [int(round(t / self.sample_time_s)) for t in S.TWO_PHASE_SWITCH_S]:
                then = self._searched(W[b, s - 1], H - s)
                block = np.empty((len(then), H, 2))
                block[:, :s] = W[b, :s]
                block[:, s:] = then
                bn = [f"{names[b]} then {n} at +{s * self.sample_time_s:g} s" for n in self._search_names[:len(then)]]
                got = self.clearances(state, block, obstacles)
                safe = got[4] == N
                if safe.any():
                    j = self._nearest(block, safe, wish)
                    self.counters["two_phase_taken"] += 1
                    self.counters["two_phase_safe"] += 1
                    return bn[j], block[j], self._verdict(got, j, obstacles, bn[j])
                j = self._best_unsafe(got)
                chk = self._verdict(got, j, obstacles, bn[j])
                if best is None or self._better(chk, best[0]):
                    best = (chk, bn[j], block[j])
        if best is None or not self._better(best[0], mc):
            return name, mw, mc
        self.counters["two_phase_taken"] += 1
        return best[1], best[2], best[0]

    F.SafetyFilter._way_out = _way_out
    print("GPCNAV_EXP_GPC_MANOEUVRE_TWO_PHASE: the GPC's way out continues its manoeuvres in two phases",
          file=sys.stderr)
