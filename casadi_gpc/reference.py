"""Reference trajectories: a path of line and arc pieces traversed at a set speed.

The desired pose at time t is the point at arc length ``min(speed * t, length)``.
Numpy only, so the deployed policy can use it.
"""
from __future__ import annotations

import math
from bisect import bisect_right
from dataclasses import dataclass

import numpy as np
from numba import njit

from .robot import arc_step

__all__ = ["Segment", "ReferencePath"]


@dataclass(frozen=True)
class Segment:
    """A piece of constant curvature: a line (``curvature_1pm`` 0) or an arc."""

    length_m: float
    curvature_1pm: float = 0.0

    @staticmethod
    def line(length_m: float) -> "Segment":
        return Segment(float(length_m), 0.0)

    @staticmethod
    def arc(radius_m: float, angle_rad: float) -> "Segment":
        """An arc; a positive angle turns left."""
        return Segment(float(radius_m * abs(angle_rad)), float(np.sign(angle_rad) / radius_m))


@dataclass(frozen=True)
class ReferencePath:
    """A desired space-time trajectory (CONTRACT: ``[reference]``)."""

    start_xy_m: tuple[float, float]
    start_heading_rad: float
    segments: tuple[Segment, ...]
    speed_mps: float

    def __post_init__(self):
        if not self.segments:
            raise ValueError("reference path has no segments")
        _refuse_unfollowable(self)
        x, y, h = float(self.start_xy_m[0]), float(self.start_xy_m[1]), float(self.start_heading_rad)
        starts, cum = [], [0.0]
        for seg in self.segments:
            starts.append((x, y, h))
            x, y, h = (float(v) for v in arc_step(np, x, y, h, 1.0, seg.curvature_1pm, seg.length_m))
            cum.append(cum[-1] + seg.length_m)
        object.__setattr__(self, "_starts", np.array(starts))
        object.__setattr__(self, "_cum", np.array(cum))
        object.__setattr__(self, "_curv", np.array([s.curvature_1pm for s in self.segments]))
        # the same table in plain floats for poses_along: (start arc length, x0, y0, h0,
        # curvature, cos h0, sin h0) per segment, and the arc lengths where they start
        object.__setattr__(self, "_cum_list", tuple(cum[:-1]))
        object.__setattr__(self, "_table", tuple((c, x0, y0, h0, seg.curvature_1pm, math.cos(h0), math.sin(h0))
                                                 for c, (x0, y0, h0), seg in zip(cum, starts, self.segments)))
        object.__setattr__(self, "_length", cum[-1])

    @property
    def length_m(self) -> float:
        return self._length

    @property
    def duration_s(self) -> float:
        """Time the reference point needs to reach the end of the path."""
        return self.length_m / self.speed_mps

    @property
    def end_pose(self) -> np.ndarray:
        return self.pose_at_arclength(self.length_m)

    def _segment_index(self, s):
        # np.minimum(np.maximum(.)) is np.clip at a fraction of the call cost
        return np.minimum(np.maximum(np.searchsorted(self._cum, s, side="right") - 1, 0), len(self.segments) - 1)

    def _arc_at(self, s):
        """``(x, y, heading)`` arrays at arc lengths ``s`` already clipped to the path."""
        i = self._segment_index(s)
        x0, y0, h0 = self._starts[i].T if np.ndim(s) else self._starts[i]
        return arc_step(np, x0, y0, h0, 1.0, self._curv[i], s - self._cum[i])

    def pose_at_arclength(self, s) -> np.ndarray:
        """Pose ``[x, y, heading]`` (shape ``(..., 3)``) at arc length ``s``, clipped to the path."""
        s = np.minimum(np.maximum(np.asarray(s, dtype=float), 0.0), self._length)
        return np.stack(self._arc_at(s), axis=-1)

    def poses_along(self, s0_m: float, step_m: float, n: int) -> list[tuple[float, float, float]]:
        """Poses ``(x, y, heading)`` at the arc lengths ``s0_m + k step_m``, k = 0..n-1,
        clipped to the path: the values of :meth:`pose_at_arclength` (the same model, on
        plain floats), for the few poses of a horizon, where numpy's per-call cost would be
        most of the time."""
        L, cum, table = self._length, self._cum_list, self._table
        last = len(cum) - 1
        out = []
        append = out.append
        lo, hi = 1.0, 0.0  # the arc lengths [lo, hi) of the last pose's segment (none yet)
        for k in range(n):
            s = s0_m + step_m * k
            if s < 0.0:  # min(max(s, 0), L), without the two calls
                s = 0.0
            elif s > L:
                s = L
            # the segment that starts at or before s (the first starts at 0 <= s): bisect's
            # answer, looked up again only when s has left the last one's
            if not lo <= s < hi:
                i = bisect_right(cum, s) - 1
                c, x0, y0, h0, curv, cos0, sin0 = table[i]
                lo, hi = c, cum[i + 1] if i < last else math.inf
            ds = s - c
            if curv == 0.0:
                # arc_step with turn rate 0: half-angle 0, sinc 1, so the chord is ds along h0
                # (bit for bit the same numbers)
                append((x0 + ds * cos0, y0 + ds * sin0, h0))
            else:
                append(arc_step(math, x0, y0, h0, 1.0, curv, ds))
        return out

    def curvature_at_arclength(self, s) -> np.ndarray:
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length_m)
        return self._curv[self._segment_index(s)]

    def arclength_at_time(self, t_s) -> np.ndarray:
        return np.clip(self.speed_mps * np.asarray(t_s, dtype=float), 0.0, self.length_m)

    def pose_at_time(self, t_s) -> np.ndarray:
        return self.pose_at_arclength(self.arclength_at_time(t_s))

    def project(self, xy, s_guess: float, window_m: float = 2.0, samples: int = 81) -> float:
        """Arc length of the path point nearest ``xy``, searched near ``s_guess``: the nearest
        of ``samples`` arc lengths spread evenly over the window (clipped to the path). On a
        window inside one straight piece (every sample of a crossing; the deployed policy
        projects every sample) the compiled :func:`_project_on_line` answers, the numbers of
        :meth:`_project_samples` bit for bit (``tests/test_reference.py``)."""
        if samples > 1:
            arrays = self.__dict__.get("_line_arrays")  # made at the first call (a path unpickled has none)
            if arrays is None:
                arrays = self.__dict__["_line_arrays"] = (np.array(self._cum_list, dtype=float),
                                                          np.array(self._table, dtype=float).reshape(-1, 7))
            s = _project_on_line(float(xy[0]), float(xy[1]), float(s_guess), float(window_m), int(samples),
                                 self._length, *arrays)
            if s == s:  # not NaN: it answered
                return s
        return self._project_samples(xy, s_guess, window_m, samples)

    def _project_samples(self, xy, s_guess: float, window_m: float = 2.0, samples: int = 81) -> float:
        """:meth:`project` in numpy, on any window."""
        s = np.linspace(s_guess - window_m, s_guess + window_m, samples)
        s = np.minimum(np.maximum(s, 0.0), self._length)
        lo, hi = float(s[0]), float(s[-1])
        i = bisect_right(self._cum_list, lo) - 1
        c, x0, y0, _, curv, cos0, sin0 = self._table[i]
        if curv == 0.0 and (i == len(self._cum_list) - 1 or hi < self._cum_list[i + 1]):
            # the window on one straight piece: the points of _arc_at there, x0 + ds cos h0
            # (see poses_along), without its segment look-ups and sinc
            ds = s - c
            d2 = (ds * cos0 + (x0 - xy[0])) ** 2 + (ds * sin0 + (y0 - xy[1])) ** 2
        else:
            x, y, _ = self._arc_at(s)
            d2 = (x - xy[0]) ** 2 + (y - xy[1]) ** 2
        return float(s[int(np.argmin(d2))])

    def polyline(self, step_m: float = 0.05) -> np.ndarray:
        n = max(2, int(np.ceil(self.length_m / step_m)) + 1)
        return self.pose_at_arclength(np.linspace(0.0, self.length_m, n))


def _refuse_unfollowable(path: ReferencePath) -> None:
    """A ``ValueError`` of one line for a path no robot can follow, as a scenario file's is refused
    (CONTRACT.md): a start, heading or speed that is not a finite number, a speed not above 0, a
    segment whose length is not finite and at least 0 or whose curvature is not finite (an arc of
    radius 0). Made in Python they were taken: a NaN start had both controllers brake at every
    decision, a speed of 0 had the network creep from a point standing at the start."""
    def finite(v) -> bool:
        try:
            return math.isfinite(v)
        except TypeError:
            return False

    try:
        x, y = path.start_xy_m
    except (TypeError, ValueError):
        x = y = math.nan
    if not (finite(x) and finite(y)):
        raise ValueError(f"reference path: start {path.start_xy_m!r} is not two finite numbers (m)")
    if not finite(path.start_heading_rad):
        raise ValueError(f"reference path: heading {path.start_heading_rad!r} is not a finite number (rad)")
    if not (finite(path.speed_mps) and path.speed_mps > 0):
        raise ValueError(f"reference path: speed {path.speed_mps!r} is not a finite number above 0 (m/s)")
    for i, seg in enumerate(path.segments):
        if not (finite(seg.length_m) and seg.length_m >= 0 and finite(seg.curvature_1pm)):
            raise ValueError(f"reference path: segment {i} has length {seg.length_m!r} m and curvature "
                             f"{seg.curvature_1pm!r} 1/m (a length finite and not negative, a finite curvature: "
                             f"an arc's radius above 0)")


@njit("float64(float64, float64, float64, float64, int64, float64, float64[::1], float64[:, ::1])", cache=True)
def _project_on_line(px, py, s_guess, window_m, samples, length, starts, table):  # pragma: no cover (compiled)
    """:meth:`ReferencePath._project_samples` where its window lies on one straight piece,
    compiled: the same arc lengths (``np.linspace``'s ``k * step + start``, the last one
    ``stop``), clipped as there, and the first nearest; NaN where the window is not on one
    straight piece (the numpy form answers). ``starts``: where the pieces start; ``table``:
    ``ReferencePath._table``'s rows."""
    start, stop = s_guess - window_m, s_guess + window_m
    div = samples - 1
    delta = stop - start
    step = delta / div
    s = np.empty(samples)
    for k in range(samples):
        v = (k / div) * delta if step == 0 else k * step
        s[k] = np.minimum(np.maximum(v + start if k < div else stop, 0.0), length)
    i = np.searchsorted(starts, s[0], side="right") - 1
    c, x0, y0, curv, cos0, sin0 = table[i, 0], table[i, 1], table[i, 2], table[i, 4], table[i, 5], table[i, 6]
    if not (curv == 0.0 and (i == starts.shape[0] - 1 or s[div] < starts[i + 1])):
        return math.nan
    best, arg = math.inf, 0
    for k in range(samples):
        ds = s[k] - c
        d2 = (ds * cos0 + (x0 - px)) ** 2 + (ds * sin0 + (y0 - py)) ** 2
        if d2 < best or (k == 0) or (d2 != d2 and best == best):
            best, arg = d2, k
            if d2 != d2:
                break  # argmin: the first NaN
    return s[arg]
