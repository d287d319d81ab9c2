"""Points and line segments in the plane, once for everyone (numpy only): the distance from a
point to a wall or a path, and whether a straight move crosses a wall. The robot's side
(the planner's wall slots and guesses) and the world (walls, sensors, path measures) both use
these."""
from __future__ import annotations

import numpy as np

__all__ = ["nearest_on_segments", "distance_to_segments_m", "segments_cross", "segment_rows", "walls_reach_m",
           "a_wall_within"]


def nearest_on_segments(points, a, b) -> np.ndarray:
    """The point of each segment ``a[k] -> b[k]`` (``(m, 2)`` each) nearest each of ``points``
    (``(..., 2)``): shape ``(..., m, 2)``. A segment of no length is its point."""
    q = np.asarray(points, dtype=float)[..., None, :]
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    ab = b - a
    t = ((q - a) * ab).sum(-1) / np.maximum((ab * ab).sum(-1), 1e-18)
    return a + np.clip(t, 0.0, 1.0)[..., None] * ab


def distance_to_segments_m(points, a, b) -> np.ndarray:
    """Distance from each of ``points`` (``(..., 2)``) to each segment, ``(..., m)``."""
    q = np.asarray(points, dtype=float)[..., None, :]
    return np.linalg.norm(q - nearest_on_segments(points, a, b), axis=-1)


def segments_cross(p, q, a, b) -> np.ndarray:
    """Whether each move ``p[i] -> q[i]`` (``(n, 2)``) crosses each segment ``a[k] -> b[k]``
    (``(m, 2)``): ``(n, m)``; touching counts as crossing (both orientation tests change
    sign or vanish). A NaN end crosses nothing."""
    p, q = np.asarray(p, dtype=float)[:, None, :], np.asarray(q, dtype=float)[:, None, :]
    a, b = np.asarray(a, dtype=float)[None], np.asarray(b, dtype=float)[None]

    def turn(o, u, v):  # z of (u - o) x (v - o)
        return (u[..., 0] - o[..., 0]) * (v[..., 1] - o[..., 1]) - (u[..., 1] - o[..., 1]) * (v[..., 0] - o[..., 0])
    with np.errstate(invalid="ignore"):
        return (turn(a, b, p) * turn(a, b, q) <= 0) & (turn(p, q, a) * turn(p, q, b) <= 0)


def segment_rows(walls) -> np.ndarray:
    """The segments of ``walls`` (polylines of ``(x, y)`` points) as rows ``(ax, ay, bx, by)``,
    shape ``(n, 4)``."""
    return np.array([(*a, *b) for pts in walls for a, b in zip(pts[:-1], pts[1:])], dtype=float).reshape(-1, 4)


def walls_reach_m(robot, horizon_s: float) -> float:
    """How far from the robot's centre a wall can matter within ``horizon_s``: its top speed
    for the whole horizon, its radius, and a metre beyond. The segments the check is handed
    (:meth:`casadi_gpc.safety.Shield.decide`) and the planner's margin near walls
    (:attr:`casadi_gpc.config.PlannerConfig.walls_margin_m`) both use it."""
    return robot.max_wheel_speed_mps * horizon_s + robot.radius_m + 1.0


def a_wall_within(walls, xy, reach_m: float) -> bool:
    """Whether a segment of ``walls`` (polylines of ``(x, y)`` points) comes within ``reach_m``
    of the point ``xy`` (the planner's test of :func:`walls_reach_m`; the check takes the
    segments themselves, :func:`casadi_gpc.safety.walls.wall_segments_within`)."""
    s = segment_rows(walls)
    return bool(len(s)) and bool((distance_to_segments_m(np.asarray(xy, dtype=float), s[:, :2], s[:, 2:])
                                  <= reach_m).any())
