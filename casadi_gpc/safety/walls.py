"""Walls for the check layer: each polyline's segments, and the robot's distance to them
measured exactly (numpy, and the compiled distances).

A wall is touched when the robot's disc touches one of its segments (the simulator's rule),
so the check's clearance to a wall is the distance from the robot's centre to the segment
minus the robot's radius, with the margin as for a static obstacle. Between two sub-samples
the robot moves on a straight chord and the wall stands still, so the smallest distance over
the chord is the distance between two segments
(:func:`~casadi_gpc.safety.distances.chord_segment_distance`), exact as the closest approach
to a disc is.

Before this, each wall was a chain of static discs 0.1 m apart (radius 0.05 m): the check saw
up to 5 cm less clearance than there is, and rolled every sequence out against hundreds of
discs in a corridor (12-39 ms a decision in the wall suites, docs/nn-deploy.md).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..geometry import map_segment_rows, segment_candidates
from .distances import path_segment_distances, point_segment_distance

__all__ = ["wall_segments", "wall_segments_within", "point_segment_distance", "path_segment_distances",
           "wall_label"]


@lru_cache(maxsize=32)
def wall_segments(walls: tuple) -> np.ndarray:
    """The segments of ``walls`` (polylines of ``(x, y)`` points, as
    :attr:`casadi_gpc.types.Observation.walls` holds them), ``(n, 2)`` complex: each row a
    segment's two ends as ``x + iy``, polyline by polyline, in order (read-only)."""
    rows = [(complex(*a), complex(*b)) for points in walls for a, b in zip(points[:-1], points[1:])]
    out = np.array(rows, dtype=complex).reshape(-1, 2)
    out.flags.writeable = False  # shared: the rows a check is given are a copy (wall_segments_within)
    return out


_LAST_MAP: tuple = (None, None, None)  # the walls last asked about: the object, its segments, its rows as floats


def _segments_and_rows(walls: tuple) -> tuple[np.ndarray, np.ndarray]:
    """The numbers of :func:`wall_segments` of ``walls`` (made from the map's one read-only array of
    ``(ax, ay, bx, by)`` rows, :func:`casadi_gpc.geometry.map_segment_rows`) and those rows, kept for
    the walls object last given: :func:`wall_segments`' cache hashes the walls, every point, which
    took 2 ms a decision for a map of 20 000 segments."""
    global _LAST_MAP
    kept = _LAST_MAP
    if walls is not kept[0]:
        rows = map_segment_rows(walls)  # the map's one array (and grid), shared with the planner and the policy
        seg = np.empty((len(rows), 2), dtype=complex)  # the same numbers as wall_segments: each x + iy, exactly
        seg.real, seg.imag = rows[:, 0::2], rows[:, 1::2]
        seg.flags.writeable = False
        kept = _LAST_MAP = (walls, seg, rows)  # one assignment: another thread reads the old entry or this, whole
    return kept[1], kept[2]


def wall_segments_within(walls: tuple, xy, reach_m: float) -> np.ndarray:
    """The rows of :func:`wall_segments` that come within ``reach_m`` of the point ``xy``: the
    only ones a robot that moves at most ``reach_m`` minus its radius over the horizon can
    touch (the check's cost grows with every segment it is given). In their order; a large map is
    read through its grid (:func:`casadi_gpc.geometry.segment_candidates`), the same rows measured
    by the same operations."""
    seg, rows = _segments_and_rows(walls)
    idx = segment_candidates(rows, float(xy[0]), float(xy[1]), reach_m)
    if idx is not None:
        seg = seg[idx]
    return seg[point_segment_distance(complex(xy[0], xy[1]), seg[:, 0], seg[:, 1]) <= reach_m]  # a copy


def wall_label(i: int) -> str:
    """The check's name for the ``i``-th segment it was given."""
    return f"wall {i}"
