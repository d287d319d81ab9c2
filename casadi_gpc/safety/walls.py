"""Walls for the check layer: each polyline as a chain of static discs that never claims
more room than the wall leaves (numpy only).

Discs of radius ``s / 2`` centred every ``s`` along a segment (both ends included) cover it:
for any point, the nearest centre is no further than ``sqrt(d^2 + (s/2)^2) <= d + s/2``
from it, ``d`` being its distance to the segment, and no nearer than ``d``. So the gap to
the nearest disc lies in ``[d - s/2, d]``: the check never sees more clearance to a wall
than there is, and sees at most ``s / 2`` less (:data:`WALL_SPACING_M`). The check's discs
are its usual static obstacles, so every plan, roll-out and manoeuvre it judges is judged
against the walls as well, for every controller behind it.
"""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ..types import StaticObstacle

__all__ = ["WALL_SPACING_M", "wall_discs", "wall_discs_within"]

WALL_SPACING_M = 0.1
"""Disc spacing along a wall: the check's clearance to a wall is at most half this below the
true one (5 cm)."""


@lru_cache(maxsize=32)
def wall_discs(walls: tuple, spacing_m: float = WALL_SPACING_M) -> tuple[StaticObstacle, ...]:
    """The static discs that stand for ``walls`` (polylines of ``(x, y)`` points, as
    :attr:`casadi_gpc.types.Observation.walls` holds them); see the module text."""
    out = []
    for points in walls:
        for (ax, ay), (bx, by) in zip(points[:-1], points[1:]):
            n = max(1, math.ceil(math.hypot(bx - ax, by - ay) / spacing_m))
            for k in range(n + 1):
                t = k / n
                out.append(StaticObstacle((ax + t * (bx - ax), ay + t * (by - ay)), 0.5 * spacing_m))
    return tuple(out)


@lru_cache(maxsize=32)
def _centres(walls: tuple, spacing_m: float) -> np.ndarray:
    return np.array([d.position_m for d in wall_discs(walls, spacing_m)], dtype=float).reshape(-1, 2)


def wall_discs_within(walls: tuple, xy, reach_m: float, spacing_m: float = WALL_SPACING_M) -> tuple:
    """The discs of :func:`wall_discs` whose centres lie within ``reach_m`` of ``xy``: the
    only ones a robot that moves at most ``reach_m`` minus its radius over the horizon can
    touch (the check's cost grows with every disc it is given)."""
    discs = wall_discs(walls, spacing_m)
    c = _centres(walls, spacing_m)
    near = np.flatnonzero(np.hypot(c[:, 0] - xy[0], c[:, 1] - xy[1]) <= reach_m)
    return tuple(discs[k] for k in near)
