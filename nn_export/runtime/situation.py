"""The situation: everything the planner knows at one sample instant, in the world frame
(the robot's state, the desired poses over the horizon, the obstacle EKF estimates, the
static obstacles), and the helpers both of its makers use (numpy only).

Two ways build a :class:`Situation`, and both use the same helpers here, so they cannot
disagree:

- the dataset sampler (:mod:`nn_export.training.sampler`) from a sampled reference path,
  robot state and noisy past obstacle measurements (:func:`reference_poses`,
  :func:`track_estimate`);
- the deployed policy from the stream of :class:`~casadi_gpc.types.Observation` with
  :class:`~nn_export.runtime.tracker.SituationTracker` (the same obstacle EKF bank and
  reference clock as the GPC).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from casadi_gpc.estimation.ekf import ObstacleEKF
from casadi_gpc.estimation.obstacle_model import FilterState, planning_covariances
from casadi_gpc.estimation.ekf_batch import MANY_TRACKS, ForecastBatch
from casadi_gpc.reference import ReferencePath
from casadi_gpc.robot import RobotState
from casadi_gpc.types import ObstacleForecast, StaticObstacle

__all__ = ["TrackEstimate", "Situation", "reference_poses", "reference_rows", "track_estimate", "track_estimates",
           "row_track_estimates", "straight_estimates"]


@dataclass(frozen=True)
class TrackEstimate:
    """A moving obstacle as its EKF sees it now, with the forecast the planner uses."""

    obstacle_id: int
    radius_m: float
    state: np.ndarray
    """EKF state ``[x_m, y_m, speed_mps, heading_rad, turn_rad_per_step]``, shape (5,)."""
    cov: np.ndarray
    """Its covariance, shape (5, 5)."""
    means_m: np.ndarray
    """Predicted positions at steps 1..H, shape (H, 2)."""
    covs_m2: np.ndarray
    """Their covariances, shape (H, 2, 2)."""
    initialised: bool = True
    """False while the filter has seen a single position: speed and heading are unknown
    (the filter assumes it stands still, with a growing uncertainty)."""

    @cached_property
    def state_values(self) -> tuple[float, ...]:
        """:attr:`state` as plain floats (what the features are computed from)."""
        return tuple(self.state.tolist())

    def forecast(self) -> ObstacleForecast:
        """What the planner plans with (:func:`casadi_gpc.estimation.ekf.planning_covariances`)."""
        return ObstacleForecast(self.obstacle_id, self.radius_m, self.means_m,
                                planning_covariances(self.covs_m2, self.initialised))


@dataclass(frozen=True)
class Situation:
    """Everything the planner knows at one sample instant, in the world frame."""

    robot: RobotState
    ref_poses: np.ndarray
    """Desired poses ``[x_m, y_m, heading_rad]`` at steps 0..H, shape (H+1, 3); step 0 is
    where the reference point is now, steps 1..H are what the GPC tracks."""
    sample_time_s: float
    ref_speed_mps: float
    """The reference's nominal speed (the GPC's initial guesses use it)."""
    tracks: tuple[TrackEstimate, ...] = ()
    statics: tuple[StaticObstacle, ...] = ()
    info: dict = field(default_factory=dict, compare=False)
    """Provenance (sampler draws), not used by the features."""
    walls: tuple = ()
    """The map's walls, each a polyline of ``(x_m, y_m)`` points (as
    :attr:`casadi_gpc.types.Observation.walls`): the planner plans with them where its NLP has
    wall slots, a ``set-walls`` layout reads them as a scan
    (:mod:`nn_export.runtime.wall_scan`)."""

    @property
    def horizon(self) -> int:
        return len(self.ref_poses) - 1

    def forecasts(self) -> list[ObstacleForecast]:
        return [t.forecast() for t in self.tracks]

    def with_reference(self, ref_poses: np.ndarray) -> "Situation":
        """The same situation with another desired trajectory (the paper's second pass uses the
        robot's predicted poses, with step 0 the robot's current pose)."""
        return replace(self, ref_poses=np.asarray(ref_poses, dtype=float))

    def without_obstacles(self) -> "Situation":
        return replace(self, tracks=(), statics=(), walls=())

    def transformed(self, rotation_rad: float, translation_m=(0.0, 0.0), mirror: bool = False) -> "Situation":
        """The situation seen in another world frame: an optional reflection about the world
        x axis, then a rotation by ``rotation_rad`` about the origin, then a translation.
        The local-frame features of the result equal the original ones (mirrored if
        ``mirror``); the GPC's answer is equivariant the same way."""
        c, s = math.cos(rotation_rad), math.sin(rotation_rad)
        sg = -1.0 if mirror else 1.0
        R = np.array([[c, -s], [s, c]]) @ np.diag([1.0, sg])
        t = np.asarray(translation_m, dtype=float)

        def pt(xy):
            return np.asarray(xy, dtype=float) @ R.T + t

        def ang(a):
            return sg * np.asarray(a, dtype=float) + rotation_rad

        r = self.robot
        x, y = pt([r.x_m, r.y_m])
        vr, vl = (r.v_left_mps, r.v_right_mps) if mirror else (r.v_right_mps, r.v_left_mps)
        robot = RobotState(float(x), float(y), float(ang(r.heading_rad)), vr, vl)
        ref = np.column_stack([pt(self.ref_poses[:, :2]), ang(self.ref_poses[:, 2])])
        J = np.eye(5)
        J[:2, :2] = R
        J[4, 4] = sg
        J[3, 3] = sg
        tracks = []
        for tr in self.tracks:
            st = tr.state.copy()
            st[:2] = pt(st[:2])
            st[3] = ang(st[3])
            st[4] = sg * st[4]
            tracks.append(replace(tr, state=st, cov=J @ tr.cov @ J.T, means_m=pt(tr.means_m),
                                  covs_m2=R @ tr.covs_m2 @ R.T))
        statics = tuple(StaticObstacle(tuple(float(v) for v in pt(s.position_m)), s.radius_m) for s in self.statics)
        walls = tuple(tuple(tuple(float(v) for v in p) for p in pt(np.asarray(w, dtype=float))) for w in self.walls)
        return replace(self, robot=robot, ref_poses=ref, tracks=tuple(tracks), statics=statics, walls=walls)

    def mirrored(self) -> "Situation":
        """Reflected about the tangent of the reference at step 0 (the paper's symmetry)."""
        x0, y0, h0 = (float(v) for v in self.ref_poses[0])
        # reflection about the line through (x0, y0) at angle h0: Rot(2 h0) diag(1, -1), and
        # the translation that keeps (x0, y0) in place
        c, s = math.cos(2.0 * h0), math.sin(2.0 * h0)
        t = (x0 - (c * x0 + s * y0), y0 - (s * x0 - c * y0))
        return self.transformed(2.0 * h0, t, mirror=True)


def reference_rows(path: ReferencePath, s0_m: float, sample_time_s: float, horizon: int) -> list[tuple]:
    """Desired poses ``(x, y, heading)`` at steps 0..H from a reference point at arc length
    ``s0_m``: the same arc lengths as :meth:`ReferenceClock.horizon_arclengths` (steps
    1..H) plus step 0."""
    return path.poses_along(s0_m, path.speed_mps * sample_time_s, horizon + 1)


def reference_poses(path: ReferencePath, s0_m: float, sample_time_s: float, horizon: int) -> np.ndarray:
    """:func:`reference_rows` as an array, shape (H + 1, 3)."""
    return np.array(reference_rows(path, s0_m, sample_time_s, horizon), dtype=float).reshape(horizon + 1, 3)


class _FilterTrack(TrackEstimate):
    """A :class:`TrackEstimate` made from a filter's frozen estimate
    (:class:`~casadi_gpc.estimation.obstacle_model.FilterState`) whose arrays (state, covariance, H-step forecast)
    are made when first read, with :meth:`ObstacleEKF.predict <casadi_gpc.estimation.ekf.ObstacleEKF.predict>`'s
    numbers. The deployed policy hands its track estimates over with every decision; the
    bare network reads only the state, a check layer behind it the forecast (made once)."""

    @cached_property
    def _filter(self):
        """The filter's frozen estimate (set when made from one; else made from its batch's row
        when first read, :meth:`~casadi_gpc.estimation.ekf_batch.ForecastBatch.snapshot`)."""
        return self.batch_.snapshot(self.batch_index_)

    @cached_property
    def state(self) -> np.ndarray:
        return self._filter.state_array()

    @cached_property
    def cov(self) -> np.ndarray:
        return self._filter.cov_array()

    _straight = False
    """Whether the forecast goes straight on (:class:`_StraightTrack`) rather than turning."""

    def _forecast(self) -> None:
        d = self.__dict__
        batch = d.get("batch_")
        if batch is None:
            means, covs = self._filter.predict(self._horizon, straight=self._straight)
        else:  # made with the other tracks of its sample (casadi_gpc.estimation.ekf_batch), rows of theirs
            means, covs = batch.arrays
            i = d["batch_index_"]
            means, covs = means[i], covs[i]
        d.update(means_m=means, covs_m2=covs)  # the fields a frozen instance holds

    @cached_property
    def means_m(self) -> np.ndarray:
        self._forecast()
        return self.__dict__["means_m"]

    @cached_property
    def covs_m2(self) -> np.ndarray:
        self._forecast()
        return self.__dict__["covs_m2"]


def track_estimate(ekf: ObstacleEKF, obstacle_id: int, radius_m: float, horizon: int) -> TrackEstimate:
    """Snapshot of a running EKF with its H-step forecast (as the GPC's ``estimate``); the
    arrays are made when first read (a :class:`TrackEstimate` all the same)."""
    return _filter_track(ekf.snapshot(), obstacle_id, radius_m, horizon)


def track_estimates(pairs, horizon: int) -> tuple[TrackEstimate, ...]:
    """:func:`track_estimate` of each ``(measurement, filter)`` pair of a bank's step
    (:meth:`~casadi_gpc.estimation.tracking.TrackBank.step`). From
    :data:`~casadi_gpc.estimation.ekf_batch.MANY_TRACKS` tracks on, their forecasts are made together
    when the first is read (:class:`~casadi_gpc.estimation.ekf_batch.ForecastBatch`, the same numbers
    up to rounding), and each track knows its row there (``batch_``, ``batch_index_``), so
    that a check can take the arrays whole."""
    if len(pairs) < MANY_TRACKS:
        out = []  # a loop: a comprehension is a function call, for one or two tracks
        for m, ekf in pairs:
            out.append(_filter_track(ekf.snapshot(), m.obstacle_id, m.radius_m, horizon))
        return tuple(out)
    snaps = [ekf.snapshot() for _, ekf in pairs]
    batch = ForecastBatch(snaps, horizon)
    return tuple(_filter_track(s, m.obstacle_id, m.radius_m, horizon, batch, i)
                 for i, (s, (m, _)) in enumerate(zip(snaps, pairs)))


def row_track_estimates(seen, sample_time_s: float, settings, horizon: int) -> tuple[TrackEstimate, ...]:
    """:func:`track_estimates` of a :class:`~casadi_gpc.estimation.track_rows.RowBank`'s step
    (``seen``: its :class:`~casadi_gpc.estimation.track_rows.SeenRows`; ``sample_time_s`` and
    ``settings``: the bank's): the same estimates, made from the sample's rows (a crowd's
    forecasts from the rows themselves, not gathered from the snapshots again)."""
    measurements, rows, counts, forecasts = seen
    if len(counts) < MANY_TRACKS:  # a few: each its estimate now (one list per row)
        return tuple([_filter_track(FilterState(tuple(r[:5]), tuple(r[5:20]), c, sample_time_s, settings),
                                    m.obstacle_id, m.radius_m, horizon)
                      for r, c, m in zip(rows.tolist(), counts, measurements)])
    states = list(map(tuple, rows[:, :5].tolist()))  # what the features read; the rest made when read
    if forecasts is not None and forecasts[0].shape[1] != horizon:
        forecasts = None
    batch = ForecastBatch.of_rows(rows, counts, sample_time_s, settings, horizon, forecasts)
    out = []  # _filter_track's fields, but the estimate: made from the batch's row when read (_FilterTrack._filter)
    for i, (s, c, m) in enumerate(zip(states, counts, measurements)):
        t = _new(_FilterTrack)
        d = t.__dict__
        d["obstacle_id"], d["radius_m"], d["initialised"] = int(m.obstacle_id), float(m.radius_m), c >= 2
        d["state_values"], d["_horizon"], d["batch_"], d["batch_index_"] = s, int(horizon), batch, i
        out.append(t)
    return tuple(out)


class _StraightTrack(_FilterTrack):
    """A :class:`_FilterTrack` whose forecast goes straight on at the estimated speed and
    heading (:meth:`FilterState.predict <casadi_gpc.estimation.obstacle_model.FilterState.predict>` with
    ``straight=True``; in a batch, a straightened one's rows: ``ForecastBatch.straightened``),
    not turning on by the estimated turn increment."""

    _straight = True


def straight_estimates(tracks: tuple) -> tuple[TrackEstimate, ...]:
    """The same track estimates (:func:`row_track_estimates`, :func:`track_estimates`) with
    their forecasts straight on at the estimated speed and heading, as the ``improved`` GPC
    forecasts (:func:`casadi_gpc.estimation.obstacle_model.straightened`): what the deployed policy hands
    its check layer, where the network's features read the turning forecast it was trained
    with. A crowd's, made together when first read (one straightened
    :class:`~casadi_gpc.estimation.ekf_batch.ForecastBatch`, so that a check takes the arrays
    whole)."""
    if not tracks:
        return tracks
    batch = getattr(tracks[0], "batch_", None)
    straight = batch.straightened() if batch is not None and all(t.batch_ is batch for t in tracks) else None
    out = []
    for t in tracks:
        s = _new(_StraightTrack)
        d, src = s.__dict__, t.__dict__
        d["obstacle_id"], d["radius_m"], d["initialised"] = t.obstacle_id, t.radius_m, t.initialised
        d["state_values"], d["_horizon"] = t.state_values, src["_horizon"]
        if straight is not None:
            d["batch_"], d["batch_index_"] = straight, src["batch_index_"]
        else:
            d["_filter"], d["batch_"], d["batch_index_"] = t._filter, None, 0
        out.append(s)
    return tuple(out)


def _filter_track(snap, obstacle_id: int, radius_m: float, horizon: int, batch: ForecastBatch | None = None,
                  index: int = 0) -> TrackEstimate:
    t = _new(_FilterTrack)  # the fields below; the arrays come from snap when read
    d = t.__dict__  # filled entry by entry (a keyword dict and update() cost a third more)
    d["obstacle_id"], d["radius_m"], d["initialised"] = int(obstacle_id), float(radius_m), snap[2] >= 2
    d["state_values"], d["_filter"], d["_horizon"] = snap[0], snap, int(horizon)
    d["batch_"], d["batch_index_"] = batch, index
    return t


_new = object.__new__
