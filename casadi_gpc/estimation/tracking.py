"""The bank of obstacle filters: one :class:`~casadi_gpc.estimation.ekf.ObstacleEKF` per obstacle id,
stepped once per sample, and the forecasts a planner plans with (numpy only).

The planner (:meth:`casadi_gpc.planner.gpc.GPCController.estimate`) keeps its tracks here; the
deployed policy's situation tracker (:class:`nn_export.runtime.tracker.SituationTracker`) keeps
the same filters in :class:`~casadi_gpc.estimation.track_rows.RowBank`, their estimates held as
arrays (the same events, counts and floats, tested against this bank), so the network sees
exactly the estimates the planner would see (their forecasts: the planner's bit for bit, or,
for the network among six tracks or more, made together by :mod:`casadi_gpc.estimation.ekf_batch`,
the same to rounding).
"""
from __future__ import annotations

import math
from collections.abc import Iterable

from .ekf import ObstacleEKF
from .obstacle_model import EKFSettings, planning_covariances, straightened
from .ekf_batch import MANY_TRACKS, forecast_many
from ..types import ObstacleForecast, ObstacleMeasurement, samples_since

__all__ = ["TrackBank", "TRACK_COUNTERS", "UPDATED_TOGETHER", "STALE_GAP_S", "counted", "missed_steps"]

UPDATED_TOGETHER = 4
"""From this many filters in a bank on, their steps are taken together in one compiled call
(:meth:`TrackBank.step`); below it, one by one in Python floats (the same numbers)."""

TRACK_COUNTERS = ("missed_measurements", "outliers", "unestimated_tracks", "manoeuvres", "ghosts", "missed_samples")
"""What a bank counts: measurements missing (or not finite; a sample without an observation
counts one for each filter), measurements gated as
outliers, tracks that have a state but have seen a single position (speed and heading
unknown; planned standing, :func:`~casadi_gpc.estimation.ekf.planning_covariances`), once per sample,
manoeuvres (two gated measurements that agree: the velocity estimated afresh) and ghosts
(samples a gated measurement waited for confirmation, its position planned as an obstacle
standing there too, :meth:`~casadi_gpc.estimation.ekf.ObstacleEKF.ghost`), and samples that
came without an observation (:func:`missed_steps`)."""


STALE_GAP_S = 60.0
"""A gap between two observations longer than this (a robot paused, a clock that jumped) leaves the
bank's tracks nothing to forecast with: :func:`missed_steps` forgets them, and every obstacle starts a
new track at its next measurement, as one back in the sensor's view. A track of a walker seen for 10 s
and then unseen has, at the default settings and any sample time, a heading std of 2.9 rad after 30 s
and 7.9 rad after 60 s, a position std of 3.5 and 9.7 m. Until 2026-12-02 the filters stepped every
missed sample one by one: a pause of a day (172 800 samples at T = 0.5 s) cost seconds a track, and
the forecast of a person standing still through 3000 s had the check reverse from them."""


def missed_steps(bank, t_s: float | None) -> int:
    """The samples between a bank's last step and one at ``t_s`` that came without an
    observation (:func:`~casadi_gpc.types.samples_since` - 1; 0 where ``t_s`` is None: one sample,
    as a caller that keeps no time says), counted as ``missed_samples``; ``t_s`` becomes the bank's
    last time. Every bank's one definition of a step's time (:class:`TrackBank`,
    :class:`~casadi_gpc.estimation.track_rows.RowBank`): its filters then step that many samples
    without a measurement before the sample's own (a walker seen 0.5 m further on after a dropped
    frame is where the filter's prediction puts it, not an outlier 0.5 m off). A gap longer than
    :data:`STALE_GAP_S` forgets the bank's tracks instead (its ``_forget``, counted ``dropped_tracks``):
    0 samples to step."""
    if t_s is None:
        return 0
    last = bank.last_t_s
    missed = samples_since(last, t_s, bank.sample_time_s) - 1  # raises before anything changes
    bank.last_t_s = t_s
    if missed:
        bank.counters["missed_samples"] += missed
        if t_s - last > STALE_GAP_S:
            bank._forget(())
            return 0
    return missed


def counted(counters: dict, ekf: ObstacleEKF, event: str) -> bool:
    """Count in ``counters`` (:data:`TRACK_COUNTERS`) the ``event`` of ``ekf``'s step (its
    :meth:`~casadi_gpc.estimation.ekf.ObstacleEKF.step`'s answer); whether the track has a state
    (is seen). Every bank counts its filters' steps here (:class:`TrackBank`,
    :class:`~casadi_gpc.estimation.track_rows.RowBank`)."""
    if event != "update":  # an update leaves an initialised track (the common case)
        if event == "missed":
            counters["missed_measurements"] += 1
        elif event == "outlier":
            counters["outliers"] += 1
        elif event == "manoeuvre":
            counters["manoeuvres"] += 1
        if not ekf.started:
            return False
        if not ekf.initialised:
            counters["unestimated_tracks"] += 1  # planned with its next step's uncertainty
    return True


class TrackBank:
    """One obstacle EKF per obstacle id, made at its first measurement.

    Parameters
    ----------
    sample_time_s : float
        T, the filters' step.
    settings : EKFSettings, optional
        The filters' noise levels.
    counters : dict, optional
        Where to count the events of :data:`TRACK_COUNTERS` (the owner's own counters, so
        that they read as one dict; a new dict by default). Missing keys start at 0.
    straight : bool
        :meth:`forecast` holds each filter's estimated speed and heading (a planner's
        ``PlannerConfig.forecast == "straight"``) instead of the paper's turning model.
    """

    def __init__(self, sample_time_s: float, settings: EKFSettings | None = None, counters: dict | None = None,
                 straight: bool = False):
        self.sample_time_s = sample_time_s
        self.straight = bool(straight)
        self.settings = settings or EKFSettings()
        self.filters: dict[int, ObstacleEKF] = {}
        self.last_t_s: float | None = None  # the time of the last step that said it (missed_steps)
        self.counters = {} if counters is None else counters
        for k in TRACK_COUNTERS:
            self.counters.setdefault(k, 0)

    def step(self, moving: Iterable[ObstacleMeasurement],
             t_s: float | None = None) -> list[tuple[ObstacleMeasurement, ObstacleEKF]]:
        """Fuse one sample's measurements (one step of every measured obstacle's filter), taken at
        ``t_s`` (where the samples since the last step's time are k > 1, every filter first steps
        k - 1 samples without a measurement: :func:`missed_steps`);
        returns the ``(measurement, filter)`` pairs of the tracks that have a state, then
        those of their ghosts (a gated measurement: the obstacle standing there,
        :meth:`~casadi_gpc.estimation.ekf.ObstacleEKF.ghost`), which every planner avoids as well.
        From :data:`UPDATED_TOGETHER` filters on, the initialised tracks' steps with a finite
        measurement are taken together (:meth:`~casadi_gpc.estimation.ekf.ObstacleEKF.update_together`:
        the same numbers), the rest one by one."""
        filters = self.filters
        for _ in range(missed_steps(self, t_s)):
            for ekf in filters.values():
                self._stepped(ekf, ekf.step(None))
        seen = []
        together = [] if len(filters) >= UPDATED_TOGETHER else None  # (filter, measured position)
        settings, T, isfinite = self.settings, self.sample_time_s, math.isfinite
        listed = 0
        for m in moving:
            listed += 1
            ekf = filters.get(m.obstacle_id)
            if ekf is None:
                ekf = filters[m.obstacle_id] = ObstacleEKF(self.sample_time_s, self.settings)
            if together is not None and ekf.measurements_seen_ >= 2 and ekf.settings is settings \
                    and ekf.sample_time_s == T:
                z = m.position_m  # the sensor's own form (the filter's step takes it so too)
                if type(z) is tuple and len(z) == 2 and type(z[0]) is float and type(z[1]) is float \
                        and isfinite(z[0]) and isfinite(z[1]):
                    together.append((ekf, z))
                    seen.append((m, ekf))
                    continue
            if self._stepped(ekf, ekf.step(m.position_m)):
                seen.append((m, ekf))
        if together:
            ok = ObstacleEKF.update_together([f for f, _ in together], [z for _, z in together])
            for (ekf, z), updated in zip(together, ok):
                if not updated:  # gated out: the filter's own step (an outlier, a manoeuvre, a restart)
                    self._stepped(ekf, ekf.step(z))  # an initialised track keeps a state: it stays seen
        if listed < len(filters):
            self._forget(moving)
        pending = False  # a ghost to add (a loop: a comprehension costs more)
        for _, ekf in seen:
            if ekf.pending_z_ is not None:
                pending = True
                break
        if not pending:
            return seen
        ghosts = [(m, ekf.ghost()) for m, ekf in seen if ekf.pending_z_ is not None]
        self.counters["ghosts"] += len(ghosts)
        return seen + ghosts

    def _stepped(self, ekf: ObstacleEKF, event: str) -> bool:
        """Count the event of a filter's step; whether the track has a state (is seen)."""
        return event == "update" or counted(self.counters, ekf, event)

    def _forget(self, moving) -> None:
        """Drop the filters of obstacles the sensor no longer lists (out of range, or gone
        from the scene): one that comes back starts a new track, not a stale one."""
        ids = {m.obstacle_id for m in moving}
        gone = [i for i in self.filters if i not in ids]
        for i in gone:
            del self.filters[i]
        self.counters["dropped_tracks"] = self.counters.get("dropped_tracks", 0) + len(gone)

    def forecasts(self, pairs, horizon: int, function=None) -> list[ObstacleForecast]:
        """:meth:`forecast` of each ``(measurement, filter)`` pair (:meth:`step`'s answer), in
        order. From :data:`~casadi_gpc.estimation.ekf_batch.MANY_TRACKS` pairs on, the filters
        seen twice or more (with the bank's sample time and process noise) are forecast
        together, in one compiled call (:func:`~casadi_gpc.estimation.ekf_batch.forecast_many`:
        :func:`~casadi_gpc.estimation.ekf_floats.propagate`'s operations in its order, the same
        numbers as one by one, tested); the others one by one."""
        if len(pairs) < MANY_TRACKS:
            return [self.forecast(m, ekf, horizon, function) for m, ekf in pairs]
        T, straight = self.sample_time_s, self.straight
        states, uppers, rows, q_all = [], [], [], None
        for i, (_, ekf) in enumerate(pairs):
            if ekf.measurements_seen_ < 2 or ekf.sample_time_s != T:
                continue
            state, upper, q = ekf._s, ekf._U, ekf._q()
            if straight:
                state, upper, q = straightened(state, upper, q)
            if q_all is None:
                q_all = q
            elif q != q_all:
                continue
            states.append(state)
            uppers.append(upper)
            rows.append(i)
        out = [None] * len(pairs)
        if rows:
            means, covs = forecast_many(states, uppers, T, q_all, horizon)
            for k, i in enumerate(rows):
                m = pairs[i][0]
                out[i] = ObstacleForecast(m.obstacle_id, m.radius_m, means[k], covs[k])  # seen twice: as forecast
        return [f if f is not None else self.forecast(m, ekf, horizon, function) for f, (m, ekf) in zip(out, pairs)]

    def forecast(self, measurement: ObstacleMeasurement, ekf: ObstacleEKF, horizon: int,
                 function=None) -> ObstacleForecast:
        """What a planner plans with: the filter's H-step prediction (straight when the bank
        says so), a track seen once kept at its next step's uncertainty
        (:func:`~casadi_gpc.estimation.obstacle_model.planning_covariances`); ``function``: the
        prediction's faster form (:meth:`~casadi_gpc.estimation.obstacle_model.FilterState.predict`)."""
        means, covs = ekf.predict(horizon, function, self.straight)
        return ObstacleForecast(measurement.obstacle_id, measurement.radius_m, means,
                                planning_covariances(covs, ekf.initialised))
