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

from .obstacle_model import _TURN_ENTRIES, FilterState, _q_diagonal, standing_forecasts
from .ekf_floats import forecast_rows, straight_noise, worst_std_rows

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


def straightened_rows(rows: np.ndarray) -> np.ndarray:
    """:func:`~casadi_gpc.estimation.obstacle_model.straightened` of each row ``(x, y, V, theta, dtheta,
    15 covariance entries)`` of ``rows`` (``(N, 20)``, a bank's rows), as a new array (the
    process noise's turn entry is the caller's to zero: :func:`~casadi_gpc.estimation.ekf_floats.straight_noise`)."""
    out = np.array(rows, dtype=float, copy=True)
    out[:, 4] = 0.0
    out[:, [5 + i for i in _TURN_ENTRIES]] = 0.0
    return out


class ForecastBatch:
    """The H-step forecasts of several filters' frozen estimates
    (:class:`~casadi_gpc.estimation.obstacle_model.FilterState`, from one bank: same sample time and settings),
    made together when first read: :meth:`FilterState.predict
    <casadi_gpc.estimation.obstacle_model.FilterState.predict>`'s numbers up to rounding, one row per estimate.
    Estimates seen once (standing, their own forecast) are made one by one. Made from the
    estimates themselves, or from a bank that holds them as rows (:meth:`of_rows`)."""

    __slots__ = ("_snapshots", "horizon", "_seen", "_rows", "_made", "_time_settings", "_arrays", "_planning",
                 "_worst", "straight")

    def __init__(self, snapshots, horizon: int):
        self._snapshots, self.horizon = tuple(snapshots), int(horizon)
        self._seen = [s.measurements_seen for s in self._snapshots]
        self._rows = self._made = self._time_settings = None
        self._arrays = self._planning = self._worst = None
        self.straight = False

    @classmethod
    def of_rows(cls, rows: np.ndarray, seen: list, sample_time_s: float, settings, horizon: int,
                forecasts: tuple | None = None) -> "ForecastBatch":
        """The batch of the estimates a bank holds as rows ``(N, 20)``, the state and the
        covariance's upper triangle (:class:`~casadi_gpc.estimation.track_rows.RowBank`; ``seen``:
        how many positions each has fused; ``sample_time_s``, ``settings``: the bank's): the
        forecasts made from the rows, not gathered from the estimates, which are made from the
        rows only when read (:meth:`snapshot`). ``forecasts``: the rows' forecasts made already,
        as if each had been seen twice (:attr:`~casadi_gpc.estimation.track_rows.SeenRows.forecasts`:
        means, covariances, worst deviations; taken as they are and made read-only)."""
        b = cls.__new__(cls)
        b._snapshots, b.horizon, b._seen, b._rows, b._made = None, int(horizon), seen, rows, forecasts
        b._time_settings = (sample_time_s, settings)
        b._arrays = b._planning = b._worst = None
        b.straight = False
        return b

    def straightened(self) -> "ForecastBatch":
        """The batch of the same estimates forecast straight on at their estimated speed and
        heading (:func:`~casadi_gpc.estimation.obstacle_model.straightened` of each; the ``improved``
        planner's model), made when first read: :meth:`FilterState.predict
        <casadi_gpc.estimation.obstacle_model.FilterState.predict>`'s ``straight=True`` numbers up to rounding."""
        if self._rows is not None:
            rows, (T, settings) = self._rows, self._time_settings
        else:
            s0 = self._snapshots[0]
            T, settings = s0.sample_time_s, s0.settings
            if any((s.settings is not settings and s.settings != settings) or s.sample_time_s != T
                   for s in self._snapshots):
                raise ValueError("a straightened batch needs one filter's noise and sample time")
            rows = np.array([(*s.state, *s.cov_upper) for s in self._snapshots], dtype=float).reshape(-1, 20)
        b = ForecastBatch.of_rows(straightened_rows(rows), list(self._seen), T, settings, self.horizon)
        b.straight = True
        return b

    @property
    def snapshots(self) -> tuple:
        """The estimates, one per row."""
        if self._snapshots is None:
            self._snapshots = tuple(self.snapshot(i) for i in range(len(self._seen)))
        return self._snapshots

    def snapshot(self, i: int):
        """The estimate of row ``i``."""
        if self._snapshots is not None:
            return self._snapshots[i]
        row = self._rows[i].tolist()
        T, settings = self._time_settings
        return FilterState(tuple(row[:5]), tuple(row[5:20]), self._seen[i], T, settings)

    def __len__(self) -> int:
        return len(self._seen)

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """Means ``(N, H, 2)`` and covariances ``(N, H, 2, 2)``, read-only."""
        if self._arrays is None:
            H, rows, made = self.horizon, self._rows, self._made
            if rows is None:
                snaps = self._snapshots
                s0 = snaps[0]
                st, T = s0.settings, s0.sample_time_s
                means, covs = forecast_many([s.state for s in snaps], [s.cov_upper for s in snaps], T,
                                            _q_diagonal(st, T), H)
                for i, s in enumerate(snaps):
                    if s.measurements_seen < 2 or (s.settings is not st and s.settings != st) or s.sample_time_s != T:
                        means[i], covs[i] = s.predict(H)  # standing, or another filter's noise: its own
            else:  # one bank's rows: one sample time and settings
                T, st = self._time_settings
                if made is not None:
                    means, covs, worst = made
                else:
                    q = _q_diagonal(st, T)
                    if self.straight:  # the turn increment neither held nor wandering (ekf.straightened)
                        q = straight_noise(q)
                    means, covs = forecast_rows(rows[:, :5], rows[:, 5:20], float(T), np.array(q), H)
                own = False
                once = [i for i, seen in enumerate(self._seen) if seen == 1]
                if once:  # standing where seen: their own forecast, all at once
                    means[once], covs[once] = standing_forecasts(rows[once], st, T, H)
                    own = True
                for i, seen in enumerate(self._seen):
                    if seen < 1:
                        means[i], covs[i] = self.snapshot(i).predict(H)
                        own = True
                if made is not None and not own:  # each row's own covariances, the planning ones: their worst
                    worst.flags.writeable = False
                    self._worst = worst
            means.flags.writeable = covs.flags.writeable = False
            self._arrays = means, covs
        return self._arrays

    @property
    def planning_covs(self) -> np.ndarray:
        """The covariances a planner plans with (:func:`~casadi_gpc.estimation.ekf.planning_covariances`
        of each row), read-only."""
        if self._planning is None:
            covs = self.arrays[1]
            once = [i for i, seen in enumerate(self._seen) if seen < 2]
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
            covs = self.planning_covs  # (the forecasts made already may bring their worst deviations)
            if self._worst is not None:
                return self._worst
            w = worst_std_rows(covs)  # compiled, worst_std_m's numbers
            w.flags.writeable = False
            self._worst = w
        return self._worst
