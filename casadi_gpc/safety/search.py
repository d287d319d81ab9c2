"""The check's searched way out (numpy only; see :mod:`casadi_gpc.safety`): when nothing of
the controller's keeps the margin, the planner-free check searches more than brake and turn
(:class:`WayOutSearch`, a part of :class:`~casadi_gpc.safety.SafetyFilter`)."""
from __future__ import annotations

import numpy as np

from .check import _TIE_M, SafetyCheck
from .obstacles import Obstacles

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
        cmin, now, chord, which, kept = self.clearances(state, W, obstacles, True)
        N, tau = self.horizon * self.substeps, self.sample_time_s / self.substeps
        safe, names = kept == N, self._search_names
        if not safe.any() and self.search_phases == 2:  # each sequence for 1 s, then one of a coarse grid
            W2, names2 = self._two_phase(W, names)
            c2 = self.clearances(state, W2, obstacles, True)
            W, names = np.concatenate([W, W2]), names + names2
            cmin, now, chord, which, kept = (np.concatenate([a, b]) for a, b in zip((cmin, now, chord, which, kept), c2))
            safe = kept == N
        if safe.any():
            w = np.asarray(wish, dtype=float)
            w = np.broadcast_to(w, (self.horizon, 2)) if w.shape == (2,) else w
            if not np.all(np.isfinite(w)):
                w = np.zeros((self.horizon, 2))
            cost = (((W - w) ** 2).sum(axis=2) * self._search_weights).sum(axis=1)
            i = int(np.argmin(np.where(safe, cost, np.inf)))
        else:  # none keeps it: among those clear of the static obstacles and walls (known, not forecast), if any
            nm = len(obstacles.moving)
            if self.search_static_first and len(obstacles.q) > nm:
                st = Obstacles(obstacles.q[nm:], obstacles.touch[nm:], (), obstacles.statics, self)
                ok = self.clearances(state, W, st, True)[4] == N
                kept = np.where(ok, kept, -1) if ok.any() else kept
            longest = kept == kept.max()
            i = int(np.argmax(longest & (cmin >= cmin[longest].max() - _TIE_M)))
            kept = np.maximum(kept, 0)
        check = SafetyCheck(bool(safe[i]), float(cmin[i]), float(now[i]), float(chord[i] + 1) * tau,
                            obstacles.label(int(which[i])), names[i], float(kept[i]) * tau)
        return names[i], W[i], check

    def _two_phase(self, W, names, switch: int = 2):
        """Each of ``W`` for ``switch`` intervals, then each of a coarse grid of held targets (mean
        -0.5, 0, 0.5, 1 x half-difference -0.5, 0, 0.5 of the limit): (M * 12, H, 2), names."""
        vmax, steps = self.robot.max_wheel_speed_mps, self.horizon - switch
        tg = np.array([(u + d, u - d) for u in (-0.5, 0.0, 0.5, 1.0) for d in (-0.5, 0.0, 0.5)]) * vmax
        tg = np.minimum(np.maximum(tg, -vmax), vmax)
        v1 = W[:, switch - 1][:, None, None, :]
        reach = self._reach[:, :steps][None]
        tail = v1 + np.minimum(np.maximum(tg[None, :, None, :] - v1, -reach), reach)      # (M, 12, steps, 2)
        out = np.empty((len(W), len(tg), self.horizon, 2))
        out[:, :, :switch] = W[:, None, :switch]
        out[:, :, switch:] = tail
        return out.reshape(-1, self.horizon, 2), [f"{n} then ({r:+.2f},{l:+.2f})" for n in names for r, l in tg]

