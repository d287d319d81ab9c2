"""The ``set`` layout's features among a crowd, with its obstacle slots compiled (numba): the
compiled twin of :func:`nn_export.runtime.features.feature_values_from` for that layout,
held to it value for value by ``tests/test_set_slots.py``.

The network's own roll-out (:mod:`nn_export.runtime.rollout`) asks for the crowd network's
features eleven times a roll-out, with each track moved along its forecast: in plain floats
some 30 us a step among ten walkers (``_Ahead`` objects, twelve moving and six static slots
of nine values, the reference windows made again). Here the slots of all the tracks are
written by one compiled call from arrays made once a roll-out (:class:`CrowdSlots`); the
wheel speeds and the reference block are :mod:`~nn_export.runtime.features`' own functions.
The decision's own features (one call) stay in plain floats where the slots hold every
obstacle: making the arrays and the compiled call's first use in a decision cost more there,
with the caches cold between decisions (measured in the simulator's loop); in a crowd larger
than the slots the decision's features come from here too (:class:`~nn_export.runtime.policy.OnnxPolicy`),
and its roll-out reads the same arrays.

It answers where the uncertainty inputs are the tracks' shared forecast batch's (a crowd's
estimates, :func:`nn_export.runtime.situation.track_estimates`); anything else
(:meth:`CrowdSlots.make` answers None) takes :func:`~nn_export.runtime.features.feature_values_from`.
With more tracks than ``k_moving`` or more static obstacles than ``k_static`` (a dense crowd:
the UCY ``students`` recordings hold 30 to 50 people) the nearest fill the slots, sorted as
the features sort them (:func:`nearest_first`); in plain floats that sort, with its ``_Ahead``
objects, was half the check's time in such a crowd.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from .features import _bump, _position_stds, _reference_values, _window_tails
from .layouts import SET_ELEMENT, FeatureLayout
from .wall_scan import wall_scan

__all__ = ["CrowdSlots", "set_slots", "nearest_first"]


_MEANS = types.Array(types.float64, 3, "C", readonly=True)  # a forecast batch's (read-only)


@njit(types.int64[::1](types.float64[:, ::1], _MEANS, types.int64, types.float64, types.float64, types.float64[:, ::1]),
      cache=True)
def nearest_first(X, means, j, rx, ry, statics):  # pragma: no cover (compiled)
    """The tracks' order, then the statics' (one array, the statics' indices after the
    tracks'), nearest first as :func:`~nn_export.runtime.features.order_by_distance` sorts
    them: a track by the least distance from ``(rx, ry)`` to where it is and to its forecast
    from then on (``j`` steps along ``means``: its positions at steps ``j..H``), a static disc
    by the distance to its centre; a stable sort, as Python's ``sorted`` (ties keep the order
    given). The distances are libm's ``hypot``, which differs from Python's ``math.hypot`` in
    the last bit of some 0.6 % of pairs (measured): two obstacles would be ordered otherwise
    only if their distances were within that bit of each other."""
    n, ns = X.shape[0], statics.shape[0]
    keys = np.empty(n)
    for i in range(n):
        if j > 0:
            d = math.hypot(means[i, j - 1, 0] - rx, means[i, j - 1, 1] - ry)
        else:
            d = math.hypot(X[i, 0] - rx, X[i, 1] - ry)
        for c in range(max(j - 1, 0), means.shape[1]):
            d = min(d, math.hypot(means[i, c, 0] - rx, means[i, c, 1] - ry))
        keys[i] = d
    skeys = np.empty(ns)
    for i in range(ns):
        skeys[i] = math.hypot(statics[i, 0] - rx, statics[i, 1] - ry)
    out = np.empty(n + ns, np.int64)
    out[:n] = np.argsort(keys, kind="mergesort") if n > 1 else np.arange(n)
    out[n:] = np.argsort(skeys, kind="mergesort") if ns > 1 else np.arange(ns)
    return out


@njit(types.UniTuple(types.int64, 2)(types.float64[::1], types.float64, types.float64, types.float64, types.float64,
                                     types.float64, types.float64[:, ::1], types.boolean[::1], types.float64[::1],
                                     types.float64[::1], _MEANS, types.int64, types.float64[:, ::1], types.int64,
                                     types.int64, types.float64, types.boolean), cache=True)
def set_slots(out, rx, ry, heading, c, s, X, init, radius, std, means, j, statics, k_moving, k_static,
              rng, ordered):  # pragma: no cover (compiled)
    """Write the ``set`` layout's obstacle slots (``9 (k_moving + k_static)`` values) into
    ``out`` for the robot at ``(rx, ry, heading)`` (``c, s`` its cosine and sine): the
    tracks ``X`` (``(n, 5)`` EKF states), ``init`` (seen twice or more), ``radius``, ``std``
    (``pos_std_m``), each moved ``j`` steps along its forecast ``means`` (``(n, H, 2)``) when
    ``j > 0`` (its heading on by ``j`` turn increments: the roll-out's ``_Ahead``), and the
    static discs ``statics`` (``(ns, 3)``: x, y, radius); those within ``rng`` of the robot
    fill the slots, empty slots are zeros. In the order given, or with ``ordered`` nearest
    first (:func:`nearest_first`; what the features do when more obstacles than slots are
    given). The same operations as ``_moving_values`` and ``_static_values`` in
    :mod:`~nn_export.runtime.features`. Returns how many tracks and statics were in range."""
    out[:] = 0.0
    n_m = 0
    n, ns = X.shape[0], statics.shape[0]
    if ordered:
        order = nearest_first(X, means, j, rx, ry, statics)
    else:
        order = np.empty(n + ns, np.int64)
        order[:n] = np.arange(n)
        order[n:] = np.arange(ns)
    for k in range(n):
        i = order[k]
        x, y, v, th, dth = X[i, 0], X[i, 1], X[i, 2], X[i, 3], X[i, 4]
        if j > 0:
            x, y, th = means[i, j - 1, 0], means[i, j - 1, 1], th + j * dth
        if not math.hypot(x - rx, y - ry) <= rng:
            continue
        if n_m < k_moving:
            dx, dy = x - rx, y - ry
            lx, ly = c * dx + s * dy, -s * dx + c * dy
            if not init[i]:
                v = dth = 0.0
            a = th + dth - heading
            o = 9 * n_m
            out[o], out[o + 1], out[o + 2], out[o + 3], out[o + 4] = 1.0, lx, ly, v * math.cos(a), v * math.sin(a)
            out[o + 5], out[o + 6], out[o + 7], out[o + 8] = dth, radius[i], std[i], 1.0
        n_m += 1
    n_s = 0
    for k in range(ns):
        i = order[n + k]
        px, py = statics[i, 0], statics[i, 1]
        if not math.hypot(px - rx, py - ry) <= rng:
            continue
        if n_s < k_static:
            dx, dy = px - rx, py - ry
            o = 9 * (k_moving + n_s)
            out[o], out[o + 1], out[o + 2], out[o + 6] = 1.0, c * dx + s * dy, -s * dx + c * dy, statics[i, 2]
        n_s += 1
    return n_m, n_s


_NO_MEANS = np.zeros((0, 0, 2))
_NO_MEANS.flags.writeable = False


class CrowdSlots:
    """A decision's tracks and static obstacles as the arrays :func:`set_slots` reads, made
    once (:meth:`make`) and read for each step of its roll-out (:meth:`values`)."""

    __slots__ = ("layout", "n_tracks", "n_statics", "X", "init", "radius", "std", "means", "statics", "_out",
                 "ordered", "wall_rows")

    @staticmethod
    def overflows(layout: FeatureLayout, tracks, statics) -> bool:
        """Whether ``layout``'s slots cannot hold them all: then the nearest fill them, sorted
        as the features sort them (both kinds, as they do)."""
        return len(tracks) > layout.k_moving or len(statics) > layout.k_static

    @classmethod
    def make(cls, layout: FeatureLayout, tracks, statics, wall_rows=None) -> "CrowdSlots | None":
        """The arrays of ``tracks`` (a crowd's estimates, rows of one forecast batch in its
        order) and ``statics`` for ``layout``, and ``wall_rows`` (the map's wall segments, as
        :func:`~nn_export.runtime.features.feature_values_from` takes them) for a layout that
        scans walls; None where :func:`set_slots` does not answer (another layout, tracks
        without a shared batch)."""
        if not layout.is_set:
            return None
        if layout.size != 2 + len(SET_ELEMENT) * (layout.k_moving + layout.k_static) + layout.horizon + 4 + \
                layout.wall_sectors:
            return None  # a layout with inputs of another kind
        batch = getattr(tracks[0], "batch_", None) if tracks else None
        if tracks and (batch is None or len(batch) != len(tracks)):
            return None
        for i, t in enumerate(tracks):
            if getattr(t, "batch_", None) is not batch or t.batch_index_ != i:
                return None
        self = cls.__new__(cls)
        self.layout, self.n_tracks, self.n_statics = layout, len(tracks), len(statics)
        self.ordered = cls.overflows(layout, tracks, statics)
        if tracks:
            self.X = np.array([t.state_values for t in tracks], dtype=float)
            self.init = np.array([t.initialised for t in tracks], dtype=bool)
            self.radius = np.array([t.radius_m for t in tracks], dtype=float)
            stds = _position_stds(tracks)  # the features' own numbers (indexed by batch_index_ = i)
            if stds is None:
                return None
            self.std = np.array(stds, dtype=float)
            means = batch.arrays[0]  # read-only
            if not means.flags.c_contiguous:
                means = np.ascontiguousarray(means)
                means.flags.writeable = False
            self.means = means
        else:
            self.X, self.init = np.zeros((0, 5)), np.zeros(0, dtype=bool)
            self.radius = self.std = np.zeros(0)
            self.means = _NO_MEANS
        self.statics = np.array([(st.position_m[0], st.position_m[1], st.radius_m) for st in statics],
                                dtype=float).reshape(-1, 3)
        self._out = np.empty(len(SET_ELEMENT) * (layout.k_moving + layout.k_static))
        self.wall_rows = wall_rows if layout.wall_sectors and wall_rows is not None and len(wall_rows) else None
        return self

    def values(self, x: float, y: float, heading: float, v_right: float, v_left: float, ref_rows: list,
               sample_time_s: float, report: dict | None = None, step: int = 0,
               window: tuple | None = None) -> list[float]:
        """:func:`~nn_export.runtime.features.feature_values_from` ``(layout, RobotState(x, y,
        heading, v_right, v_left), ref_rows, sample_time_s, tracks, statics, report, wall_rows)``; with
        ``step`` j > 0, of the tracks moved j steps along their forecasts (the roll-out's).
        ``window``: the reference window's tail (:func:`~nn_export.runtime.features._window_tails`
        of ``ref_rows``) when the caller has it."""
        layout = self.layout
        rx, ry, heading = float(x), float(y), float(heading)
        c, s = math.cos(heading), math.sin(heading)
        ordered = self.ordered
        n_m, n_s = set_slots(self._out, rx, ry, heading, c, s, self.X, self.init, self.radius, self.std,
                             self.means if step or ordered else _NO_MEANS, step, self.statics, layout.k_moving,
                             layout.k_static, layout.range_m, ordered)
        if report is not None and (self.n_tracks or self.n_statics):
            out = (self.n_tracks - n_m) + (self.n_statics - n_s)
            if out:
                _bump(report, "out_of_range", out)
            if n_m > layout.k_moving:
                _bump(report, "dropped_moving", n_m - layout.k_moving)
            if n_s > layout.k_static:
                _bump(report, "dropped_static", n_s - layout.k_static)
        f = [v_right, v_left]
        f += self._out.tolist()
        if window is None:
            n = layout.horizon + 1
            window = _window_tails(layout, ref_rows if len(ref_rows) == n else ref_rows[:n], sample_time_s)[0]
        f += _reference_values(rx, ry, heading, ref_rows[1], window, report, c, s)
        if layout.wall_sectors:  # the scan from here, as the features take it
            f += [layout.wall_range_m] * layout.wall_sectors if self.wall_rows is None else \
                wall_scan(self.wall_rows, rx, ry, heading, layout.wall_sectors, layout.wall_range_m)
        return f
