"""The obstacle filter's H-step forecast for many tracks at once (numpy and the compiled
forecast).

:func:`forecast_many` hands the N tracks' states and covariances to
:func:`casadi_gpc.estimation.ekf_floats.forecast_rows` in one call: :func:`~casadi_gpc.estimation.ekf_floats.propagate`'s
numbers, bit for bit (tested), compiled. (Before, the H steps of N tracks were taken in
closed form over the horizon with some 45 numpy calls: about 80 us for ten tracks quiet, 150
us inside the deployed decision; the compiled loop takes 4.5 us quiet.)
"""
from __future__ import annotations

import numpy as np

from .ekf import _q_diagonal
from .ekf_floats import forecast_rows, worst_std_rows

__all__ = ["forecast_many", "ForecastBatch", "MANY_TRACKS"]

MANY_TRACKS = 6
"""From this many tracks on, a bank's forecasts are made together (:func:`forecast_many`),
as arrays a check takes whole (:class:`ForecastBatch`); below it, each track's own forecast
when first read (the same numbers)."""


def forecast_many(states, uppers, sample_time_s: float, q: tuple, horizon: int) -> tuple[np.ndarray, np.ndarray]:
    """The predicted positions ``(N, H, 2)`` and their covariances ``(N, H, 2, 2)`` at steps
    1..H of N filter states ``(x, y, V, theta, dtheta)`` (``(N, 5)``) with their covariances'
    upper triangles (``(N, 15)``, row by row: :data:`casadi_gpc.estimation.ekf_floats.upper`), all with
    the same sample time and Q diagonal ``q``: :func:`casadi_gpc.estimation.ekf_floats.forecast` of
    each, together."""
    flat = []  # one array of both (in a decision among walkers each numpy call costs more than the arithmetic)
    for st, u in zip(states, uppers):
        flat += (*st, *u)
    rows = np.array(flat, dtype=float).reshape(-1, 20)
    return forecast_rows(rows[:, :5], rows[:, 5:], float(sample_time_s), np.array(q, dtype=float), int(horizon))


class ForecastBatch:
    """The H-step forecasts of several filters' frozen estimates
    (:class:`~casadi_gpc.estimation.ekf.FilterState`, from one bank: same sample time and settings),
    made together when first read: :meth:`FilterState.predict
    <casadi_gpc.estimation.ekf.FilterState.predict>`'s numbers up to rounding, one row per estimate.
    Estimates seen once (standing, their own forecast) are made one by one."""

    __slots__ = ("snapshots", "horizon", "_arrays", "_planning", "_worst")

    def __init__(self, snapshots, horizon: int):
        self.snapshots, self.horizon = tuple(snapshots), int(horizon)
        self._arrays = self._planning = self._worst = None

    def __len__(self) -> int:
        return len(self.snapshots)

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """Means ``(N, H, 2)`` and covariances ``(N, H, 2, 2)``, read-only."""
        if self._arrays is None:
            snaps, H = self.snapshots, self.horizon
            s0 = snaps[0]
            means, covs = forecast_many([s.state for s in snaps], [s.cov_upper for s in snaps], s0.sample_time_s,
                                        _q_diagonal(s0.settings, s0.sample_time_s), H)
            st, T = s0.settings, s0.sample_time_s
            for i, s in enumerate(snaps):
                if s.measurements_seen < 2 or (s.settings is not st and s.settings != st) or s.sample_time_s != T:
                    means[i], covs[i] = s.predict(H)  # standing, or another filter's noise: its own
            means.flags.writeable = covs.flags.writeable = False
            self._arrays = means, covs
        return self._arrays

    @property
    def planning_covs(self) -> np.ndarray:
        """The covariances a planner plans with (:func:`~casadi_gpc.estimation.ekf.planning_covariances`
        of each row), read-only."""
        if self._planning is None:
            covs = self.arrays[1]
            once = [i for i, s in enumerate(self.snapshots) if s.measurements_seen < 2]
            if once:
                covs = covs.copy()
                covs[once] = covs[once, :1]
                covs.flags.writeable = False
            self._planning = covs
        return self._planning

    @property
    def worst_std_m(self) -> np.ndarray:
        """:func:`~casadi_gpc.estimation.ekf.worst_std_m` of :attr:`planning_covs`, ``(N, H)``, read-only
        (the check's touching distances widen by it)."""
        if self._worst is None:
            w = worst_std_rows(self.planning_covs)  # compiled, worst_std_m's numbers
            w.flags.writeable = False
            self._worst = w
        return self._worst
