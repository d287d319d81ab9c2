"""The network's input feature values: one definition for dataset generation, training and
the deployed policy (numpy only). The layouts (which inputs, in which order) are
:mod:`nn_export.runtime.layouts`; the situation they are computed from,
:mod:`nn_export.runtime.situation`.

Everything is expressed in the robot's local frame: origin at the robot's centre, x forward
along its heading, y to its left. A situation is first gathered in the world frame as a
:class:`Situation` (what the planner knows at one sample instant: the robot's state, the
desired poses over the horizon, the obstacle EKF estimates, the static obstacles);
:func:`compute_features` turns it into the network's input vector.

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
The ``set`` layout's slots are one set (its network does not see their order): they are
filled in the order given unless more obstacles are in range than there are slots, and an
empty slot is all zeros (``present`` 0).

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
from functools import reduce
from operator import add

import numpy as np

from casadi_gpc.robot import RobotState, sinc
from casadi_gpc.types import StaticObstacle

from .layouts import FeatureLayout
from .situation import Situation, TrackEstimate
from .wall_scan import scan_rows, wall_scan, wall_segment_rows

__all__ = ["order_by_distance", "compute_features", "feature_values", "feature_values_from", "compute_features_batch",
           "RolloutFeatures", "mirror_features", "wrap_pi"]

_TWO_PI = 2.0 * math.pi
_SHORT_ARC_M = 1e-6  # below this, two desired poses are one point and carry no curvature


def wrap_pi(a):
    """Angle(s) wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a, dtype=float), _TWO_PI)


def order_by_distance(robot_xy, tracks=(), statics=()) -> tuple[list, list]:
    """Tracks and static obstacles, nearest first (current and predicted positions)."""
    rx, ry = float(robot_xy[0]), float(robot_xy[1])
    hypot = math.hypot

    def key_track(t: TrackEstimate):
        x, y = t.state_values[:2]
        d = hypot(x - rx, y - ry)
        for mx, my in t.means_m.tolist():
            d = min(d, hypot(mx - rx, my - ry))
        return d

    # one of each needs no distances (the common case)
    return (sorted(tracks, key=key_track) if len(tracks) > 1 else list(tracks),
            sorted(statics, key=lambda s: hypot(s.position_m[0] - rx, s.position_m[1] - ry)) if len(statics) > 1
            else list(statics))


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
    kappas, lengths, clipped = [], [], []  # clipped: the arcs whose curvature was clipped
    cos, sin, pi, short = math.cos, math.sin, math.pi, _SHORT_ARC_M
    x0, y0, h0 = P[0]
    straight, cs, sn = None, 1.0, 0.0  # the heading of the last straight piece, its cosine and sine
    total = 0.0  # the lengths added in order from 0.0 (sum() may compensate, depending on the version)
    for x1, y1, h1 in P[1:]:
        # the exact arc through consecutive poses: chord = L sinc(dth/2) along the mid heading
        if h1 == h0:
            # a straight piece: dth = 0 and sinc(0) = 1 exactly, so the same numbers as below
            # with the cosine and sine of h0 + 0.0 (not -0.0) kept while the heading stays
            if h0 != straight:
                straight = h0
                cs, sn = cos(h0 + 0.0), sin(h0 + 0.0)
            length = (x1 - x0) * cs + (y1 - y0) * sn
            kappa = 0.0 / length if length > short or length < -short else 0.0
            clip = lim < 0.0  # a curvature of +-0 passes any limit that is not negative
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
            clip = True
        if clip and (kappa > lim or kappa < -lim):  # abs(kappa) > lim
            kappa = math.copysign(lim, kappa)
            clipped.append(len(kappas))
        kappas.append(kappa)
        lengths.append(length)
        total += length
        x0, y0, h0 = x1, y1, h1
    HT = H * T
    if len(kappas) == H:  # one window (the decision's own desired poses)
        kappas.append(total / HT)
        return [(kappas, len(clipped))]
    out = []
    for j in range(len(P) - H):
        tail = kappas[j:j + H]
        tail.append(reduce(add, lengths[j:j + H], 0.0) / HT)
        out.append((tail, sum(j <= i < j + H for i in clipped) if clipped else 0))
    return out


def _reference_values(x: float, y: float, heading: float, p1, window: tuple[list, int], report,
                      c: float | None = None, s: float | None = None) -> list:
    """The reference features for the robot at ``(x, y, heading)``: the first desired point
    ``p1`` in its frame, then the window's tail (:func:`_window_tails`); ``c, s``: the
    cosine and sine of ``heading`` when the caller has them."""
    if c is None:
        c, s = math.cos(heading), math.sin(heading)
    dx, dy = p1[0] - x, p1[1] - y
    tail, n_clipped = window
    if n_clipped and report is not None:
        report["curvature_clipped"] = report.get("curvature_clipped", 0) + n_clipped
    # the heading: _wrap(p1[2] - heading), written out
    return [c * dx + s * dy, -s * dx + c * dy, math.pi - (math.pi - (p1[2] - heading)) % _TWO_PI, *tail]


def _moving_values(layout: FeatureLayout, rx: float, ry: float, heading: float, c: float, s: float,
                   tr: TrackEstimate | None, stds: list | None = None) -> list:
    """The slot of a moving obstacle for the robot at ``(rx, ry, heading)``, ``c, s`` the
    cosine and sine of its heading; ``stds``: :func:`_position_stds` of the track's
    forecast batch, when the caller made them."""
    if tr is None:
        return list(layout.absent_moving)
    x, y, v, th, dth = tr.state_values
    dx, dy = x - rx, y - ry
    lx, ly = c * dx + s * dy, -s * dx + c * dy
    if layout.is_set:
        if not tr.initialised:
            v = dth = 0.0
        a = th + dth - heading  # the velocity's direction in the robot's frame
        std = _position_std(tr) if stds is None else stds[tr.batch_index_]
        return [1.0, lx, ly, v * math.cos(a), v * math.sin(a), dth, tr.radius_m, std, 1.0]
    if tr.initialised:
        vals = [lx, ly, v, (th + dth - heading) % _TWO_PI, dth]
    else:  # one position seen: standing still as far as anyone knows, heading unknown
        vals = [lx, ly, 0.0, math.pi, 0.0]
    if layout.flags:
        vals = [1.0] + vals + [tr.radius_m, _position_std(tr) if stds is None else stds[tr.batch_index_]]
    return vals


def _position_std(tr: TrackEstimate) -> float:
    """``pos_std_m``: the RMS standard deviation of the predicted position at step H,
    sqrt(trace(cov_H) / 2) (the current one when there is no forecast)."""
    cov_h = tr.covs_m2[-1] if len(tr.covs_m2) else tr.cov[:2, :2]
    return math.sqrt(max(0.5 * float(np.trace(cov_h)), 0.0))


def _position_stds(tracks) -> list | None:
    """:func:`_position_std` of every row of the forecast batch that ``tracks`` share
    (:class:`~casadi_gpc.estimation.ekf_batch.ForecastBatch`: a crowd's track estimates, made together),
    in one go and the same numbers, indexed by ``batch_index_``; None when they share none.
    Reading each track's forecast row instead cost most of the features' time among ten
    walkers (measured)."""
    batch = getattr(tracks[0], "batch_", None) if tracks else None
    if batch is None or batch.horizon < 1:
        return None
    for t in tracks:
        if getattr(t, "batch_", None) is not batch:
            return None
    cov_h = batch.arrays[1][:, -1]
    return np.sqrt(np.maximum(0.5 * (cov_h[:, 0, 0] + cov_h[:, 1, 1]), 0.0)).tolist()


def _static_values(layout: FeatureLayout, rx: float, ry: float, c: float, s: float,
                   st: StaticObstacle | None) -> list:
    if st is None:
        return list(layout.absent_static)
    dx, dy = st.position_m[0] - rx, st.position_m[1] - ry
    if layout.is_set:
        return [1.0, c * dx + s * dy, -s * dx + c * dy, 0.0, 0.0, 0.0, st.radius_m, 0.0, 0.0]
    return [1.0, c * dx + s * dy, -s * dx + c * dy, st.radius_m]


def feature_values(layout: FeatureLayout, situation: Situation, report: dict | None = None) -> list[float]:
    """:func:`compute_features` as a list of plain floats (what the deployed policy writes
    into the network's input row in one go)."""
    if situation.horizon != layout.horizon:
        raise ValueError(f"situation has horizon {situation.horizon}, layout {layout.name!r} wants {layout.horizon}")
    ref_poses = np.asarray(situation.ref_poses, dtype=float)
    if ref_poses.shape != (layout.horizon + 1, 3):
        raise ValueError(f"expected desired poses of shape {(layout.horizon + 1, 3)}, got {ref_poses.shape}")
    statics, wall_rows = situation.statics, None
    if layout.wall_sectors and situation.walls:  # the static discs in the scan, as the deployed policy gives them
        wall_rows, statics = scan_rows(wall_segment_rows(situation.walls), statics)
    return feature_values_from(layout, situation.robot, ref_poses.tolist(), situation.sample_time_s, situation.tracks,
                               statics, report, wall_rows)


def feature_values_from(layout: FeatureLayout, robot: RobotState, ref_rows: list, sample_time_s: float,
                        tracks=(), statics=(), report: dict | None = None, wall_rows=None) -> list[float]:
    """:func:`feature_values` of the situation made of these pieces, the H + 1 desired
    poses given as rows ``(x, y, heading)`` (unchecked: the caller's; the deployed policy's
    second pass builds no :class:`Situation` for them). ``wall_rows``: the map's wall
    segments ``(ax, ay, bx, by)`` (:func:`~nn_export.runtime.wall_scan.wall_segment_rows`;
    None: no walls), which a layout with a wall scan reads."""
    r = robot
    # plain floats (a simulator's state may hold numpy scalars, whose arithmetic costs more;
    # the numbers are the same)
    rx, ry, heading = float(r.x_m), float(r.y_m), float(r.heading_rad)
    c, s = math.cos(heading), math.sin(heading)
    f = [r.v_right_mps, r.v_left_mps]
    if tracks or statics:
        # a set's order does not matter: the nearest are sorted out only when more than
        # its slots are in range (the forecasts the sort reads are then made)
        if (len(tracks) > 1 or len(statics) > 1) and not (
                layout.is_set and len(tracks) <= layout.k_moving and len(statics) <= layout.k_static):
            tracks, statics = order_by_distance((rx, ry), tracks, statics)
        rng, hypot = layout.range_m, math.hypot
        # loops, not comprehensions (each one a function call, for one or two obstacles)
        in_range, st_in = [], []
        for t in tracks:
            sv = t.state_values
            if hypot(sv[0] - rx, sv[1] - ry) <= rng:
                in_range.append(t)
        for st in statics:
            p = st.position_m
            if hypot(p[0] - rx, p[1] - ry) <= rng:
                st_in.append(st)
        k_moving, k_static = layout.k_moving, layout.k_static
        n_moving, n_static = len(in_range), len(st_in)
        if report is not None:
            out = (len(tracks) - n_moving) + (len(statics) - n_static)
            if out:
                _bump(report, "out_of_range", out)
            if n_moving > k_moving:
                _bump(report, "dropped_moving", n_moving - k_moving)
            if n_static > k_static:
                _bump(report, "dropped_static", n_static - k_static)
        stds = _position_stds(in_range[:k_moving]) if layout.flags or layout.is_set else None
        for j in range(k_moving):
            f += _moving_values(layout, rx, ry, heading, c, s, in_range[j] if j < n_moving else None, stds)
        if k_static:
            for j in range(k_static):
                f += _static_values(layout, rx, ry, c, s, st_in[j] if j < n_static else None)
    else:
        f += layout._absent_obstacles
    n = layout.horizon + 1
    window = _window_tails(layout, ref_rows if len(ref_rows) == n else ref_rows[:n], sample_time_s)[0]
    f += _reference_values(rx, ry, heading, ref_rows[1], window, report, c, s)
    if layout.wall_sectors:
        if wall_rows is None or not len(wall_rows):
            f += [layout.wall_range_m] * layout.wall_sectors
        else:
            f += wall_scan(wall_rows, rx, ry, heading, layout.wall_sectors, layout.wall_range_m)
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
        self._no_walls = (layout.wall_range_m,) * layout.wall_sectors  # and no wall: the scan reads its range

    def values(self, j: int, x: float, y: float, heading: float, v_right: float, v_left: float,
               report: dict | None = None) -> list[float]:
        """Window ``j``'s features for the robot at ``(x, y, heading)`` with wheel speeds
        ``(v_right, v_left)``, as a list of plain floats."""
        if not 0 <= j < self.windows:
            raise IndexError(f"window {j} of {self.windows}")
        return [v_right, v_left, *self._absent,
                *_reference_values(x, y, heading, self._P[j + 1], self._windows[j], report), *self._no_walls]

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
