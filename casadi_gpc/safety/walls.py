"""Walls for the check layer: each polyline's segments, and the robot's distance to them
measured exactly (numpy only).

A wall is touched when the robot's disc touches one of its segments (the simulator's rule),
so the check's clearance to a wall is the distance from the robot's centre to the segment
minus the robot's radius, with the margin as for a static obstacle. Between two sub-samples
the robot moves on a straight chord and the wall stands still, so the smallest distance over
the chord is the distance between two segments (:func:`chord_segment_distance`), exact as the
closest approach to a disc is.

Before this, each wall was a chain of static discs 0.1 m apart (radius 0.05 m): the check saw
up to 5 cm less clearance than there is, and rolled every sequence out against hundreds of
discs in a corridor (12-39 ms a decision in the wall suites, docs/nn-deploy.md).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

__all__ = ["wall_segments", "wall_segments_within", "point_segment_distance", "chord_segment_distance",
           "wall_label"]


@lru_cache(maxsize=32)
def wall_segments(walls: tuple) -> np.ndarray:
    """The segments of ``walls`` (polylines of ``(x, y)`` points, as
    :attr:`casadi_gpc.types.Observation.walls` holds them), ``(n, 2)`` complex: each row a
    segment's two ends as ``x + iy``, polyline by polyline, in order (read-only)."""
    rows = [(complex(*a), complex(*b)) for points in walls for a, b in zip(points[:-1], points[1:])]
    out = np.array(rows, dtype=complex).reshape(-1, 2)
    out.flags.writeable = False
    return out


def wall_segments_within(walls: tuple, xy, reach_m: float) -> np.ndarray:
    """The rows of :func:`wall_segments` that come within ``reach_m`` of the point ``xy``: the
    only ones a robot that moves at most ``reach_m`` minus its radius over the horizon can
    touch (the check's cost grows with every segment it is given)."""
    seg = wall_segments(walls)
    if not len(seg):
        return seg
    d = point_segment_distance(complex(xy[0], xy[1]), seg[:, 0], seg[:, 1])
    return seg if bool((d <= reach_m).all()) else seg[d <= reach_m]


def _abs(z: np.ndarray) -> np.ndarray:
    return np.hypot(z.real, z.imag)


def point_segment_distance(p, a, b) -> np.ndarray:
    """Distance from the points ``p`` to the segments ``a``-``b`` (complex, broadcast)."""
    d = b - a
    r = p - a
    dd = d.real * d.real + d.imag * d.imag
    t = np.divide(r.real * d.real + r.imag * d.imag, dd, out=np.zeros(np.broadcast(r, dd).shape), where=dd > 0.0)
    t = np.minimum(np.maximum(t, 0.0), 1.0)
    return _abs(r - t * d)


def _cross(u, v):
    """The z component of u x v (complex as 2-vectors)."""
    return u.real * v.imag - u.imag * v.real


def chord_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest distance between each chord of the paths ``p`` (``(..., N + 1)``
    complex: consecutive points) and each segment ``a``-``b`` (``(n,)`` complex):
    ``(..., n, N)``. Zero where a chord crosses a segment; else the least of the four
    end-to-segment distances (the distance between two segments that do not cross)."""
    P = p[..., None, :]                                     # (..., 1, N + 1)
    A, B = a[:, None], b[:, None]                           # (n, 1)
    ends = point_segment_distance(P, A, B)                  # (..., n, N + 1): path points to the walls
    d = np.minimum(ends[..., :-1], ends[..., 1:])
    p0, p1 = P[..., :-1], P[..., 1:]
    d = np.minimum(d, point_segment_distance(A, p0, p1))    # the walls' ends to the chords
    d = np.minimum(d, point_segment_distance(B, p0, p1))
    u, w = p1 - p0, B - A
    crosses = ((_cross(u, A - p0) * _cross(u, B - p0)) < 0.0) & ((_cross(w, p0 - A) * _cross(w, p1 - A)) < 0.0)
    return np.where(crosses, 0.0, d)


def wall_label(i: int) -> str:
    """The check's name for the ``i``-th segment it was given."""
    return f"wall {i}"
