"""The check's searched way out (numpy only; see :mod:`casadi_gpc.safety`): when nothing of
the controller's keeps the margin, the planner-free check searches more than brake and turn
(:class:`WayOutSearch`, a part of :class:`~casadi_gpc.safety.SafetyFilter`)."""
from __future__ import annotations

import numpy as np

from .check import _TIE_M, SafetyCheck

__all__ = ["WayOutSearch"]


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
        :meth:`best_manoeuvre`. Returns the name, (H, 2) wheels and the check."""
        state = np.asarray(state, float)
        v0 = state[3:5]
        W = np.concatenate([self._searched(v0, self.horizon), self.manoeuvres(v0)[1]])
        cmin, now, chord, which, kept, contact = self.clearances(state, W, obstacles, True)
        N, tau = self.horizon * self.substeps, self.sample_time_s / self.substeps
        safe, names = kept == N, self._search_names
        if safe.any():
            w = np.asarray(wish, dtype=float)
            w = np.broadcast_to(w, (self.horizon, 2)) if w.shape == (2,) else w
            if not np.all(np.isfinite(w)):
                w = np.zeros((self.horizon, 2))
            cost = (((W - w) ** 2).sum(axis=2) * self._search_weights).sum(axis=1)
            i = int(np.argmin(np.where(safe, cost, np.inf)))
        else:  # the check's order (TrajectoryCheck._better): the expected discs first
            first = contact == contact.max()
            longest = first & (kept == kept[first].max())
            i = int(np.argmax(longest & (cmin >= cmin[longest].max() - _TIE_M)))
        check = SafetyCheck(bool(safe[i]), float(cmin[i]), float(now[i]), float(chord[i] + 1) * tau,
                            obstacles.label(int(which[i])), names[i], float(kept[i]) * tau,
                            contact_s=float(contact[i]) * tau)
        return names[i], W[i], check
