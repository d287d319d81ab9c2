"""The check's searched way out (numpy only; see :mod:`casadi_gpc.safety`): when nothing of
the controller's keeps the margin, the planner-free check searches more than brake and turn
(:class:`WayOutSearch`, a part of :class:`~casadi_gpc.safety.SafetyFilter`)."""
from __future__ import annotations

import numpy as np

from .check import SafetyCheck
from .ranking import best_unsafe_index

__all__ = ["WayOutSearch", "TWO_PHASE_BASES", "TWO_PHASE_SWITCH_S"]

TWO_PHASE_BASES = 4
"""The searched sequences, best first by the check's order, that a two-phase search continues
with a second target (:meth:`WayOutSearch.search`, ``search_two_phase``)..."""
TWO_PHASE_SWITCH_S = (1.0,)
"""... after this long on the first (whole samples: the first sample's command is always the
first target's, as the robot will drive it). Switching after 1 s and 2 s (twice the
sequences, twice the time where none keeps the margin) measured no safer on development seed
3 (docs/nn-deploy.md, "A way out in two phases")."""


class WayOutSearch:
    """:meth:`search` for a :class:`~casadi_gpc.safety.check.TrajectoryCheck` (its
    ``clearances``, ``manoeuvres``, ``_searched`` and the grid it builds)."""

    def search(self, state, obstacles, wish) -> tuple[str, np.ndarray, SafetyCheck]:
        """A way out searched among more than the fixed manoeuvres: every target of the grid
        :data:`SEARCH_SPEEDS` x :data:`SEARCH_TURNS` and every manoeuvre, approached at the
        acceleration limit from the current wheel speeds. Among those that keep the margin
        over the whole horizon, the one nearest the controller's wish ``wish`` ((2,) held, or
        (H, 2): its plan), by the wheel speeds' squared differences weighted 1/k at step k
        (the least change to what the controller wanted: it is still the one that drives
        towards the goal); when none keeps the margin that long, the best by the order of
        :meth:`best_manoeuvre` (with ``search_two_phase``, first among these and their
        continuations with a second target: :meth:`_two_phase`). Returns the name, (H, 2)
        wheels and the check."""
        state = np.asarray(state, float)
        v0 = state[3:5]
        W = np.concatenate([self._searched(v0, self.horizon), self.manoeuvres(v0)[1]])
        # the grid's rows that are manoeuvres too are the same sequences: measured once (_set_rows),
        # their numbers taken for both (_set_order)
        order = self._set_order
        found = tuple(a[order] for a in self.clearances(state, W[self._set_rows], obstacles))
        safe = found[4] == self.horizon * self.substeps
        any_safe = bool(safe.any())
        i = self._nearest(W, safe, wish) if any_safe else self._best_unsafe(found)  # else the check's own order
        name = self._search_names[i]
        check = self._verdict(found, i, obstacles, name)
        if not any_safe and self.search_two_phase:
            two = self._two_phase(state, obstacles, W, found, wish, single=check)
            if two is not None:
                return two
        return name, W[i], check

    def _nearest(self, W: np.ndarray, safe: np.ndarray, wish) -> int:
        """The index of the safe sequence of ``W`` nearest the controller's ``wish`` (:meth:`search`)."""
        w = np.asarray(wish, dtype=float)
        w = np.broadcast_to(w, (self.horizon, 2)) if w.shape == (2,) else w
        if not np.all(np.isfinite(w)):
            w = np.zeros((self.horizon, 2))
        cost = (((W - w) ** 2).sum(axis=2) * self._search_weights).sum(axis=1)
        return int(np.argmin(np.where(safe, cost, np.inf)))

    def _two_phase(self, state, obstacles, W: np.ndarray, found: tuple, wish, names=None, single=None):
        """Where no searched sequence keeps the margin: the best :data:`TWO_PHASE_BASES` of them
        (the check's order), each followed for each of :data:`TWO_PHASE_SWITCH_S` and then by
        every target of the grid, approached at the acceleration limit from the wheel speeds
        reached (back off, then go round). Tried best base first, the earlier switch first: the
        first of these batches with a sequence that keeps the margin gives the one of them
        nearest ``wish``; when none has, the best continuation of all, if it is better than the
        best single sequence by the check's order; else None (the single sequence stands).
        ``names``: the sequences of ``W`` by name (default: the searched set's, as :meth:`search`
        builds ``W``); ``single``: the best single sequence's check, when the caller has it.
        Counted ``two_phase_searched``, ``two_phase_taken`` and ``two_phase_safe``."""
        self.counters["two_phase_searched"] += 1
        names = self._search_names if names is None else names
        H, N = self.horizon, self.horizon * self.substeps
        cmin, kept, contact, fixed, drives, rdrives = (np.array(found[k]) for k in (0, 4, 5, 6, 7, 8))
        bases = []
        for _ in range(min(TWO_PHASE_BASES, len(cmin))):
            b = int(best_unsafe_index(cmin, kept, contact, fixed, drives, rdrives, self._commit_chords))
            bases.append(b)
            # out of the next pick
            cmin[b], kept[b], contact[b], fixed[b], drives[b], rdrives[b] = -np.inf, -1, -1, -1, -1, -1
        switches = [s for s in (int(round(t / self.sample_time_s)) for t in TWO_PHASE_SWITCH_S) if 1 <= s < H]
        best = None  # (check, name, wheels) of the best unsafe continuation so far
        for b in bases:
            for s in switches:
                then = self._searched(W[b, s - 1], H - s)
                block = np.empty((len(then), H, 2))
                block[:, :s] = W[b, :s]
                block[:, s:] = then
                got = self.clearances(state, block, obstacles)
                safe = got[4] == N
                if safe.any():
                    j = self._nearest(block, safe, wish)
                    label = self._two_phase_label(names[b], j, s)
                    self.counters["two_phase_taken"] += 1
                    self.counters["two_phase_safe"] += 1
                    return label, block[j], self._verdict(got, j, obstacles, label)
                j = self._best_unsafe(got)
                label = self._two_phase_label(names[b], j, s)  # (the one named: 38 names a batch cost 20 us)
                chk = self._verdict(got, j, obstacles, label)
                if best is None or self._better(chk, best[0]):
                    best = (chk, label, block[j])
        if single is None:
            single = self._verdict(found, self._best_unsafe(found), obstacles, "")
        if best is None or not self._better(best[0], single):
            return None
        self.counters["two_phase_taken"] += 1
        return best[1], best[2], best[0]

    def _two_phase_label(self, base: str, j: int, switch: int) -> str:
        """The name of continuation ``j`` of the sequence named ``base`` switched at step ``switch``."""
        return f"{base} then {self._search_names[j]} at +{switch * self.sample_time_s:g} s"
