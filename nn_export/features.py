"""The network's input features: one definition for dataset generation, training and the
deployed policy (numpy only).

Everything is expressed in the robot's local frame: origin at the robot's centre, x forward
along its heading, y to its left. A situation is first gathered in the world frame as a
:class:`Situation` (what the planner knows at one sample instant: the robot's state, the
desired poses over the horizon, the obstacle EKF estimates, the static obstacles);
:func:`compute_features` turns it into the network's input vector. Two ways build a
:class:`Situation`, and both use the same helpers here, so they cannot disagree:

- the dataset sampler (``nn_export.sampler``) from a sampled reference path, robot state and
  noisy past obstacle measurements (:func:`reference_poses`, :func:`track_estimate`);
- the deployed policy from the stream of :class:`~casadi_gpc.types.Observation` with
  :class:`SituationTracker` (the same obstacle EKF and reference clock as the GPC).

Layouts
-------
``paper`` (17 inputs when H = 6; ``11 + H`` in general), the paper's Fig. 4:

===  =========================  ======  ================================================
#    name                       unit    meaning
===  =========================  ======  ================================================
0    ``v_right_prev_mps``       m/s     right wheel speed applied over the last interval
1    ``v_left_prev_mps``        m/s     left wheel speed applied over the last interval
2    ``mov1_x_m``               m       nearest moving obstacle, EKF position now, local x
3    ``mov1_y_m``               m       ... local y
4    ``mov1_speed_mps``         m/s     EKF speed V(k+1) (= V(k), constant-speed model)
5    ``mov1_heading_rad``       rad     EKF heading theta(k+1) = theta + dtheta, relative to
                                        the robot's heading, wrapped to [0, 2 pi)
6    ``mov1_turn_rad``          rad     EKF heading increment per sample dtheta(k+1)
7    ``ref_x_m``                m       first desired point (step 1), local x
8    ``ref_y_m``                m       ... local y
9    ``ref_heading_rad``        rad     its heading relative to the robot's, in (-pi, pi]
10+  ``ref_curvature_{k}_1pm``  1/m     k = 1..H: curvature of the arc that joins desired
                                        pose k-1 to desired pose k (pose 0: where the
                                        reference point is now)
last ``ref_speed_mps``          m/s     mean desired speed: arc length from pose 0 to pose H
                                        divided by H T
===  =========================  ======  ================================================

``multi`` (``6 + 8 K_moving + 4 K_static + H`` inputs; 48 for K = 3, H = 6; 54 for H = 12):
the two wheel speeds; then for each of the K nearest moving obstacles ``movj_present`` (1 or 0), ``x``,
``y``, ``speed``, ``heading``, ``turn`` (as above), ``radius_m`` and ``pos_std_m`` (the RMS
standard deviation of its predicted position at step H, sqrt(trace(cov_H)/2), which sets the
planner's uncertainty weight); then for each of the K nearest static obstacles
``staj_present``, ``x``, ``y``, ``radius_m``; then the same reference block as ``paper``.
The paper layout has no radius and no uncertainty input (the paper's 17 inputs); its
network learns the average answer over the sampler's radius range.

Absent obstacles
----------------
An empty slot (no obstacle, or one farther than ``range_m`` = 12 m from the robot) is
encoded as a standing obstacle parked at the edge of the range straight behind the robot:
x = -range_m, y = 0, speed 0, heading pi (the middle of its range), turn 0, and in
``multi`` present 0, radius 0, pos_std 0. This is what the planner itself does with such
an obstacle: 12 m behind the robot and standing still, it changes the GPC's answer by a
negligible amount under ``paper`` (the term xi / (P d^2) has a gradient of about 0.004
m^-1 there) and by nothing under ``improved`` (the influence range is 1.5 m). So the
encoding is a real, harmless situation rather than an out-of-distribution code, and the
one-hidden-layer network needs no gating. Obstacles beyond the range are counted
(``report["out_of_range"]``); ones that do not fit the layout's slots are counted
(``report["dropped_moving"]``, ``report["dropped_static"]``).

A track that has seen a single position (its speed and heading are unknown; the EKF
predicts it standing still with a growing uncertainty) is encoded at its position with
speed 0, heading pi and turn 0, like the absent obstacle's motion.

Which obstacles fill the slots: the nearest first, by the smallest distance from the
robot's current position to the obstacle's current or predicted positions (steps 1..H).

Angles: the obstacle heading is wrapped to [0, 2 pi) because the common and critical case
is an obstacle coming towards the robot (relative heading near pi), where a (-pi, pi] wrap
would jump; the wrap's seam sits at "moving the same way as the robot", where the answer
varies slowly with heading. Curvatures are clipped to +-``curvature_limit_1pm`` (a robot
turning on the spot has infinite curvature), counted in ``report["curvature_clipped"]``.

Mirror symmetry: reflecting the world about any line negates every local y, angle, turn
and curvature and swaps the two wheels; :func:`mirror_features` applies that to feature
vectors (the obstacle heading maps to (2 pi - h) mod 2 pi).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property, reduce
from itertools import chain
from operator import add

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.ekf import EKFSettings, ObstacleEKF, planning_covariances
from casadi_gpc.progress import ReferenceClock
from casadi_gpc.reference import ReferencePath
from casadi_gpc.robot import RobotState, sinc
from casadi_gpc.types import Observation, ObstacleForecast, StaticObstacle

__all__ = [
    "FEATURE_VERSION", "LAYOUTS", "OBSTACLE_RANGE_M", "CURVATURE_LIMIT_1PM", "FeatureLayout", "layout_for",
    "layout_from_dict", "TrackEstimate", "Situation", "reference_poses", "track_estimate", "order_by_distance",
    "compute_features", "feature_values", "feature_values_from", "compute_features_batch", "RolloutFeatures", "mirror_features",
    "SituationTracker", "wrap_pi",
]

FEATURE_VERSION = 1
"""Bumped whenever the meaning of any feature changes; datasets and models carry it."""
LAYOUTS = ("paper", "multi")
OBSTACLE_RANGE_M = 12.0
"""Obstacles farther than this from the robot are encoded as absent (and parked here)."""
CURVATURE_LIMIT_1PM = 5.0
"""Curvature features are clipped to +-this (a 0.2 m turning radius)."""
_TWO_PI = 2.0 * math.pi
_SHORT_ARC_M = 1e-6  # below this, two desired poses are one point and carry no curvature


def wrap_pi(a):
    """Angle(s) wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a, dtype=float), _TWO_PI)


# --------------------------------------------------------------------------------------
# layouts
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FeatureLayout:
    """Which inputs, in which order. ``name`` + ``version`` identify the meaning."""

    name: str
    horizon: int
    k_moving: int
    k_static: int
    version: int = FEATURE_VERSION
    range_m: float = OBSTACLE_RANGE_M
    curvature_limit_1pm: float = CURVATURE_LIMIT_1PM

    @property
    def flags(self) -> bool:
        """Whether obstacle slots carry presence flags, radius and uncertainty (``multi``)."""
        return self.name == "multi"

    @cached_property
    def feature_names(self) -> tuple[str, ...]:
        names = ["v_right_prev_mps", "v_left_prev_mps"]
        for j in range(1, self.k_moving + 1):
            block = ["x_m", "y_m", "speed_mps", "heading_rad", "turn_rad"]
            if self.flags:
                block = ["present"] + block + ["radius_m", "pos_std_m"]
            names += [f"mov{j}_{b}" for b in block]
        for j in range(1, self.k_static + 1):
            names += [f"sta{j}_{b}" for b in ("present", "x_m", "y_m", "radius_m")]
        names += ["ref_x_m", "ref_y_m", "ref_heading_rad"]
        names += [f"ref_curvature_{k}_1pm" for k in range(1, self.horizon + 1)]
        names += ["ref_speed_mps"]
        return tuple(names)

    @property
    def size(self) -> int:
        return len(self.feature_names)

    @property
    def moving_width(self) -> int:
        return 8 if self.flags else 5

    @cached_property
    def _absent_obstacles(self) -> tuple[float, ...]:
        """The obstacle slots of a situation without obstacles (all of them empty)."""
        return (*_moving_values(self, None, None) * self.k_moving, *_static_values(self, None, None) * self.k_static)

    @cached_property
    def _mirror(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(permutation, signs, heading indices) of the mirror map."""
        names = self.feature_names
        perm = np.arange(self.size)
        perm[0], perm[1] = 1, 0
        signs = np.ones(self.size)
        for i, n in enumerate(names):
            if n.endswith(("_y_m", "_turn_rad")) or n in ("ref_heading_rad",) or n.startswith("ref_curvature_"):
                signs[i] = -1.0
        heading = np.array([i for i, n in enumerate(names) if n.endswith("_heading_rad") and n.startswith("mov")],
                           dtype=int)
        return perm, signs, heading

    def index(self, name: str) -> int:
        return self.feature_names.index(name)

    def to_dict(self) -> dict:
        """What travels with every dataset and model."""
        return {"name": self.name, "version": self.version, "horizon": self.horizon,
                "k_moving": self.k_moving, "k_static": self.k_static, "range_m": self.range_m,
                "curvature_limit_1pm": self.curvature_limit_1pm, "size": self.size,
                "feature_names": list(self.feature_names)}


def layout_for(name: str, horizon: int, k: int = 3) -> FeatureLayout:
    """The ``paper`` layout (one moving obstacle, no static) or ``multi`` (``k`` of each)."""
    if name not in LAYOUTS:
        raise ValueError(f"unknown feature layout {name!r} (choose from {', '.join(LAYOUTS)})")
    if int(horizon) < 1:
        raise ValueError(f"horizon must be at least 1, got {horizon}")
    if name == "paper":
        return FeatureLayout("paper", int(horizon), 1, 0)
    if int(k) < 1:
        raise ValueError(f"k must be at least 1, got {k}")
    return FeatureLayout("multi", int(horizon), int(k), int(k))


def layout_from_dict(d: dict) -> FeatureLayout:
    """The layout a dataset or model was made with; refuses versions and names this code
    does not produce (one clear ``ValueError``)."""
    try:
        name, version, horizon = d["name"], int(d["version"]), int(d["horizon"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"feature layout description is incomplete: {d!r}") from None
    if version != FEATURE_VERSION:
        raise ValueError(f"feature layout {name!r} version {version} is not the version this code computes "
                         f"({FEATURE_VERSION})")
    lay = layout_for(name, horizon, int(d.get("k_moving", 3)))
    lay = replace(lay, k_moving=int(d.get("k_moving", lay.k_moving)), k_static=int(d.get("k_static", lay.k_static)),
                  range_m=float(d.get("range_m", lay.range_m)),
                  curvature_limit_1pm=float(d.get("curvature_limit_1pm", lay.curvature_limit_1pm)))
    names = d.get("feature_names")
    if names is not None and tuple(names) != lay.feature_names:
        raise ValueError(f"feature names of layout {name!r} v{version} do not match this code's")
    return lay


# --------------------------------------------------------------------------------------
# situations (world frame)
# --------------------------------------------------------------------------------------
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

    def forecast(self) -> ObstacleForecast:
        """What the planner plans with (:func:`casadi_gpc.ekf.planning_covariances`)."""
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
        return replace(self, tracks=(), statics=())

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
        return replace(self, robot=robot, ref_poses=ref, tracks=tuple(tracks), statics=statics)

    def mirrored(self) -> "Situation":
        """Reflected about the tangent of the reference at step 0 (the paper's symmetry)."""
        x0, y0, h0 = (float(v) for v in self.ref_poses[0])
        # reflection about the line through (x0, y0) at angle h0: Rot(2 h0) diag(1, -1), and
        # the translation that keeps (x0, y0) in place
        c, s = math.cos(2.0 * h0), math.sin(2.0 * h0)
        t = (x0 - (c * x0 + s * y0), y0 - (s * x0 - c * y0))
        return self.transformed(2.0 * h0, t, mirror=True)


def reference_poses(path: ReferencePath, s0_m: float, sample_time_s: float, horizon: int) -> np.ndarray:
    """Desired poses at steps 0..H from a reference point at arc length ``s0_m``: the same
    arc lengths as :meth:`ReferenceClock.horizon_arclengths` (steps 1..H) plus step 0."""
    n = horizon + 1
    return np.fromiter(chain.from_iterable(path.poses_along(s0_m, path.speed_mps * sample_time_s, n)), float,
                       3 * n).reshape(n, 3)


def track_estimate(ekf: ObstacleEKF, obstacle_id: int, radius_m: float, horizon: int) -> TrackEstimate:
    """Snapshot of a running EKF with its H-step forecast (as the GPC's ``estimate``)."""
    means, covs = ekf.predict(horizon)
    return TrackEstimate(int(obstacle_id), float(radius_m), ekf.state_.copy(), ekf.cov_.copy(), means, covs,
                         bool(ekf.initialised))


def order_by_distance(robot_xy, tracks=(), statics=()) -> tuple[list, list]:
    """Tracks and static obstacles, nearest first (current and predicted positions)."""
    rx, ry = float(robot_xy[0]), float(robot_xy[1])
    hypot = math.hypot

    def key_track(t: TrackEstimate):
        x, y = t.state[:2].tolist()
        d = hypot(x - rx, y - ry)
        for mx, my in t.means_m.tolist():
            d = min(d, hypot(mx - rx, my - ry))
        return d

    # one of each needs no distances (the common case)
    return (sorted(tracks, key=key_track) if len(tracks) > 1 else list(tracks),
            sorted(statics, key=lambda s: hypot(s.position_m[0] - rx, s.position_m[1] - ry)) if len(statics) > 1
            else list(statics))


# --------------------------------------------------------------------------------------
# the features
# --------------------------------------------------------------------------------------
def _bump(report, key, n=1):
    if report is not None and n:
        report[key] = report.get(key, 0) + n


def _wrap(a: float) -> float:
    """Scalar :func:`wrap_pi` (plain floats are several times faster here)."""
    return math.pi - (math.pi - a) % _TWO_PI


# Everything below is written with plain floats and lists: the deployed policy computes
# the features of H + 1 situations per decision, and numpy's per-call overhead on vectors
# of a few elements was most of its time (measured). The values are assembled in a list
# and written into the network's input in one go.
def _window_tails(layout: FeatureLayout, P: list, T: float) -> list[tuple[list, int]]:
    """For each window of H + 1 consecutive desired poses in ``P`` (rows ``[x, y, heading]``,
    windows starting at 0, 1, ...): the last H + 1 reference features, the curvatures of
    the H arcs that join consecutive poses (clipped) and the mean desired speed (their
    total length over H T), and how many curvatures were clipped. Overlapping windows
    share the arcs."""
    H, lim = layout.horizon, layout.curvature_limit_1pm
    kappas, lengths, clipped = [], [], [0]  # clipped: running count, from 0
    cos, sin, pi, short = math.cos, math.sin, math.pi, _SHORT_ARC_M
    x0, y0, h0 = P[0]
    for x1, y1, h1 in P[1:]:
        # the exact arc through consecutive poses: chord = L sinc(dth/2) along the mid heading
        if h1 == h0:  # a straight piece: dth = 0 and sinc(0) = 1 exactly, so the same numbers
            dth = 0.0
            mid = h0 + 0.0
            length = (x1 - x0) * cos(mid) + (y1 - y0) * sin(mid)
        else:
            dth = pi - (pi - (h1 - h0)) % _TWO_PI  # _wrap(h1 - h0), inline
            half = 0.5 * dth
            mid = h0 + half
            # the robot model's own sinc, on plain floats
            length = ((x1 - x0) * cos(mid) + (y1 - y0) * sin(mid)) / sinc(math, half)
        if length > short or length < -short:  # abs(length) > short
            kappa = dth / length
        else:  # one point: no curvature, unless it turns on the spot (infinite)
            kappa = math.copysign(math.inf, dth) if abs(dth) > 1e-9 else 0.0
        if kappa > lim or kappa < -lim:  # abs(kappa) > lim
            kappa = math.copysign(lim, kappa)
            clipped.append(clipped[-1] + 1)
        else:
            clipped.append(clipped[-1])
        kappas.append(kappa)
        lengths.append(length)
        x0, y0, h0 = x1, y1, h1
    HT = H * T
    out = []
    for j in range(len(P) - H):
        tail = kappas[j:j + H]
        # the lengths added in order from 0.0 (sum() may compensate, depending on the version)
        tail.append(reduce(add, lengths[j:j + H], 0.0) / HT)
        out.append((tail, clipped[j + H] - clipped[j]))
    return out


def _reference_values(x: float, y: float, heading: float, p1, window: tuple[list, int], report) -> list:
    """The reference features for the robot at ``(x, y, heading)``: the first desired point
    ``p1`` in its frame, then the window's tail (:func:`_window_tails`)."""
    c, s = math.cos(heading), math.sin(heading)
    dx, dy = p1[0] - x, p1[1] - y
    tail, n_clipped = window
    if n_clipped and report is not None:
        report["curvature_clipped"] = report.get("curvature_clipped", 0) + n_clipped
    return [c * dx + s * dy, -s * dx + c * dy, _wrap(p1[2] - heading), *tail]


def _moving_values(layout: FeatureLayout, robot: RobotState | None, tr: TrackEstimate | None) -> list:
    if tr is None:
        vals = [-layout.range_m, 0.0, 0.0, math.pi, 0.0]
        return [0.0] + vals + [0.0, 0.0] if layout.flags else vals
    heading = robot.heading_rad
    c, s = math.cos(heading), math.sin(heading)
    x, y, v, th, dth = tr.state.tolist()
    dx, dy = x - robot.x_m, y - robot.y_m
    if tr.initialised:
        vals = [c * dx + s * dy, -s * dx + c * dy, v, (th + dth - heading) % _TWO_PI, dth]
    else:  # one position seen: standing still as far as anyone knows, heading unknown
        vals = [c * dx + s * dy, -s * dx + c * dy, 0.0, math.pi, 0.0]
    if layout.flags:
        cov_h = tr.covs_m2[-1] if len(tr.covs_m2) else tr.cov[:2, :2]
        vals = [1.0] + vals + [tr.radius_m, math.sqrt(max(0.5 * float(np.trace(cov_h)), 0.0))]
    return vals


def _static_values(layout: FeatureLayout, robot: RobotState | None, st: StaticObstacle | None) -> list:
    if st is None:
        return [0.0, -layout.range_m, 0.0, 0.0]
    c, s = math.cos(robot.heading_rad), math.sin(robot.heading_rad)
    dx, dy = st.position_m[0] - robot.x_m, st.position_m[1] - robot.y_m
    return [1.0, c * dx + s * dy, -s * dx + c * dy, st.radius_m]


def feature_values(layout: FeatureLayout, situation: Situation, report: dict | None = None) -> list[float]:
    """:func:`compute_features` as a list of plain floats (what the deployed policy writes
    into the network's input row in one go)."""
    if situation.horizon != layout.horizon:
        raise ValueError(f"situation has horizon {situation.horizon}, layout {layout.name!r} wants {layout.horizon}")
    ref_poses = np.asarray(situation.ref_poses, dtype=float)
    if ref_poses.shape != (layout.horizon + 1, 3):
        raise ValueError(f"expected desired poses of shape {(layout.horizon + 1, 3)}, got {ref_poses.shape}")
    return feature_values_from(layout, situation.robot, ref_poses.tolist(), situation.sample_time_s, situation.tracks,
                               situation.statics, report)


def feature_values_from(layout: FeatureLayout, robot: RobotState, ref_rows: list, sample_time_s: float,
                        tracks=(), statics=(), report: dict | None = None) -> list[float]:
    """:func:`feature_values` of the situation made of these pieces, the H + 1 desired
    poses given as rows ``(x, y, heading)`` (unchecked: the caller's; the deployed policy's
    second pass builds no :class:`Situation` for them)."""
    r = robot
    rx, ry = r.x_m, r.y_m
    f = [r.v_right_mps, r.v_left_mps]
    if tracks or statics:
        tracks, statics = order_by_distance((rx, ry), tracks, statics)
        rng, hypot = layout.range_m, math.hypot
        in_range = [t for t in tracks if hypot(float(t.state[0]) - rx, float(t.state[1]) - ry) <= rng]
        st_in = [s for s in statics if hypot(s.position_m[0] - rx, s.position_m[1] - ry) <= rng]
        if report is not None:
            _bump(report, "out_of_range", (len(tracks) - len(in_range)) + (len(statics) - len(st_in)))
            _bump(report, "dropped_moving", max(len(in_range) - layout.k_moving, 0))
            _bump(report, "dropped_static", max(len(st_in) - layout.k_static, 0))
        for j in range(layout.k_moving):
            f += _moving_values(layout, r, in_range[j] if j < len(in_range) else None)
        for j in range(layout.k_static):
            f += _static_values(layout, r, st_in[j] if j < len(st_in) else None)
    else:
        f += layout._absent_obstacles
    f += _reference_values(rx, ry, r.heading_rad, ref_rows[1], _window_tails(layout, ref_rows, sample_time_s)[0],
                           report)
    return f


def compute_features(layout: FeatureLayout, situation: Situation, out: np.ndarray | None = None,
                     report: dict | None = None) -> np.ndarray:
    """The input vector of ``layout`` for ``situation`` (shape ``(layout.size,)``).

    ``out``: a preallocated float64 buffer to fill (the deployed policy reuses one).
    ``report``: a dict whose counters (``out_of_range``, ``dropped_moving``,
    ``dropped_static``, ``curvature_clipped``) are incremented, so nothing is lost silently.
    """
    f = np.empty(layout.size) if out is None else out
    f[:] = feature_values(layout, situation, report)
    return f


class RolloutFeatures:
    """The features of the obstacle-free situations along a roll-out (the deployed policy's
    first pass): the robot at some state, the desired poses ``ref_poses[j:j + H + 1]``
    (window ``j``) and no obstacle.

    :meth:`fill` equals ``compute_features(layout, Situation(RobotState(x, y, heading,
    v_right, v_left), ref_poses[j:j + H + 1], T, speed), out, report)`` (tested): the same
    pieces, with the arc terms that overlapping windows share computed once and the
    absent-obstacle slots written once.
    """

    def __init__(self, layout: FeatureLayout, ref_poses: np.ndarray, sample_time_s: float):
        ref_poses = np.asarray(ref_poses, dtype=float)
        if ref_poses.ndim != 2 or ref_poses.shape[1] != 3 or len(ref_poses) < layout.horizon + 1:
            raise ValueError(f"expected desired poses of shape (n >= {layout.horizon + 1}, 3), got {ref_poses.shape}")
        self.layout, self.sample_time_s = layout, float(sample_time_s)
        self.windows = len(ref_poses) - layout.horizon
        self._P = ref_poses.tolist()
        self._windows = _window_tails(layout, self._P, self.sample_time_s)
        # the empty obstacle slots, as compute_features writes them for a situation without obstacles
        self._absent = layout._absent_obstacles

    def values(self, j: int, x: float, y: float, heading: float, v_right: float, v_left: float,
               report: dict | None = None) -> list[float]:
        """Window ``j``'s features for the robot at ``(x, y, heading)`` with wheel speeds
        ``(v_right, v_left)``, as a list of plain floats."""
        if not 0 <= j < self.windows:
            raise IndexError(f"window {j} of {self.windows}")
        return [v_right, v_left, *self._absent,
                *_reference_values(x, y, heading, self._P[j + 1], self._windows[j], report)]

    def fill(self, j: int, x: float, y: float, heading: float, v_right: float, v_left: float, out: np.ndarray,
             report: dict | None = None) -> np.ndarray:
        """:meth:`values` into ``out`` (any float dtype, shape ``(layout.size,)``)."""
        out[:] = self.values(j, x, y, heading, v_right, v_left, report)
        return out


def compute_features_batch(layout: FeatureLayout, situations, report: dict | None = None) -> np.ndarray:
    """``compute_features`` for many situations, shape ``(N, layout.size)``."""
    situations = list(situations)
    F = np.empty((len(situations), layout.size))
    for i, s in enumerate(situations):
        compute_features(layout, s, F[i], report)
    return F


def mirror_features(layout: FeatureLayout, F: np.ndarray) -> np.ndarray:
    """Features of the mirrored situation: local y, angles, turns and curvatures negated,
    the two wheels swapped, the obstacle heading h mapped to (2 pi - h) mod 2 pi.
    Works on one vector or a batch (last axis)."""
    perm, signs, heading = layout._mirror
    M = np.asarray(F, dtype=float)[..., perm] * signs
    if heading.size:
        M[..., heading] = np.mod(-M[..., heading], _TWO_PI)
    return M


# --------------------------------------------------------------------------------------
# the deployed path: observations in, situations out
# --------------------------------------------------------------------------------------
class SituationTracker:
    """Builds the :class:`Situation` from the stream of observations, exactly as the GPC
    does: one :class:`ObstacleEKF` per obstacle id, stepped once per sample, and the
    preset's :class:`ReferenceClock`. ``update(observation)`` once per sample.

    Used by the deployed policy and by on-policy (DAgger) labelling, so the network sees
    what the planner would see.
    """

    def __init__(self, config: PlannerConfig, ekf_settings: EKFSettings | None = None,
                 reference_steps: int | None = None):
        self.config = config
        self.ekf_settings = ekf_settings or EKFSettings()
        # desired poses computed per update (steps 0..reference_steps, at least H): the
        # two-pass policy needs 2H - 1, and one call is cheaper than two
        self.reference_steps = max(int(reference_steps or config.horizon), config.horizon)
        self.reference_ahead_: np.ndarray | None = None
        self.reset()

    def reset(self) -> None:
        self.reference_ahead_ = None
        self.tracks: dict[int, ObstacleEKF] = {}
        self.clock = ReferenceClock(self.config.sample_time_s, self.config.max_lead_m)
        self.counters = {"missed_measurements": 0, "outliers": 0}

    def observe(self, obs: Observation) -> None:
        """Fuse one sample's measurements and advance the clock, without building the
        situation (for samples whose decision is not wanted)."""
        self._fuse(obs)
        self.clock.update(obs.reference, obs.t_s, (obs.robot.x_m, obs.robot.y_m))

    def update(self, obs: Observation) -> Situation:
        """Fuse one sample and return the situation at it (call once per sample).
        ``reference_ahead_`` then holds the desired poses at steps 0..``reference_steps``
        (the situation's are its first H + 1)."""
        H, T = self.config.horizon, self.config.sample_time_s
        seen = self._fuse(obs)
        tracks = tuple(track_estimate(ekf, m.obstacle_id, m.radius_m, H) for m, ekf in seen)
        self.clock.update(obs.reference, obs.t_s, (obs.robot.x_m, obs.robot.y_m))
        ref = self.reference_ahead_ = reference_poses(obs.reference, self.clock.s_m, T, self.reference_steps)
        return Situation(obs.robot, ref[:H + 1], T, obs.reference.speed_mps, tracks, tuple(obs.static))

    def _fuse(self, obs: Observation) -> list:
        """Step every measured obstacle's EKF (as ``GPCController.estimate``); returns the
        (measurement, filter) pairs of the tracks that have a state."""
        seen = []
        for m in obs.moving:
            ekf = self.tracks.get(m.obstacle_id)
            if ekf is None:
                ekf = self.tracks[m.obstacle_id] = ObstacleEKF(self.config.sample_time_s, self.ekf_settings)
            event = ekf.step(m.position_m)
            if event == "missed":
                self.counters["missed_measurements"] += 1
            elif event == "outlier":
                self.counters["outliers"] += 1
            if ekf.state_ is not None:
                seen.append((m, ekf))
        return seen
