"""The check's searched way out (numpy only; see :mod:`casadi_gpc.safety`): when nothing of
the controller's keeps the margin, the planner-free check searches more than brake and turn
(:class:`WayOutSearch`, a part of :class:`~casadi_gpc.safety.SafetyFilter`)."""
from __future__ import annotations

import numpy as np

from .check import SafetyCheck

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
        # the grid's rows that are manoeuvres too are the same sequences: measured once (_set_rows),
        # their numbers taken for both (_set_order)
        order = self._set_order
        found = tuple(a[order] for a in self.clearances(state, W[self._set_rows], obstacles))
        safe = found[4] == self.horizon * self.substeps
        if safe.any():
            w = np.asarray(wish, dtype=float)
            w = np.broadcast_to(w, (self.horizon, 2)) if w.shape == (2,) else w
            if not np.all(np.isfinite(w)):
                w = np.zeros((self.horizon, 2))
            cost = (((W - w) ** 2).sum(axis=2) * self._search_weights).sum(axis=1)
            i = int(np.argmin(np.where(safe, cost, np.inf)))
        else:  # the check's own order
            i = self._best_unsafe(found)
        name = self._search_names[i]
        return name, W[i], self._verdict(found, i, obstacles, name)
