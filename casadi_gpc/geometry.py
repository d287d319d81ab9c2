"""Points and line segments in the plane, once for everyone (numpy only): the distance from a
point to a wall or a path, and whether a straight move crosses a wall. The robot's side
(the planner's wall slots and guesses) and the world (walls, sensors, path measures) both use
these."""
from __future__ import annotations

import math

import numpy as np

__all__ = ["nearest_on_segments", "distance_to_segments_m", "segments_cross", "segment_rows", "walls_reach_m",
           "a_wall_within", "segments_near", "wall_scan", "wall_scans"]


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


def segments_near(rows: np.ndarray, x: float, y: float, reach_m: float) -> np.ndarray:
    """The rows of ``rows`` (:func:`segment_rows`) that come within ``reach_m`` of the
    point ``(x, y)``."""
    if not len(rows):
        return rows
    a, d = rows[:, :2] - (x, y), rows[:, 2:] - rows[:, :2]
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-18)
    t = np.clip(-np.einsum("ij,ij->i", a, d) / dd, 0.0, 1.0)
    gap = np.hypot(a[:, 0] + t * d[:, 0], a[:, 1] + t * d[:, 1])
    return rows[gap <= reach_m]


_EDGES: dict = {}


def _edges(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The unit vectors of every sector's first and second edge, ``(n, 2)`` each."""
    if n not in _EDGES:
        centre = np.arange(n) * (2.0 * math.pi / n)
        half = math.pi / n
        _EDGES[n] = (np.column_stack([np.cos(centre - half), np.sin(centre - half)]),
                     np.column_stack([np.cos(centre + half), np.sin(centre + half)]))
    return _EDGES[n]


def wall_scan(rows: np.ndarray, x: float, y: float, heading: float, n: int, range_m: float) -> list[float]:
    """A range sensor's scan of the wall segments ``rows`` (``(ax, ay, bx, by)``,
    :func:`segment_rows`, in the world frame) from ``(x, y)`` facing ``heading`` (rad), reduced
    by its minimum over each of ``n`` equal sectors: ``n`` distances (m), sector ``k`` centred
    on the direction ``k * 2 pi / n`` in that frame (0 straight ahead, counter-clockwise), each
    the distance to the nearest point of any segment inside the sector, capped at ``range_m``.

    Computed exactly from the segments: the points of a segment ``a + t (b - a)`` that lie in a
    sector (a convex wedge narrower than a half-plane) form one interval of ``t``, bounded by
    the two linear conditions that the point is left of the sector's first edge and right of
    its second; the distance to the centre is convex in ``t``, so its minimum over the interval
    is at the foot of the perpendicular clamped into it (tested against a dense sampling). The
    networks' scan (:mod:`nn_export.runtime.wall_scan`) and the walkers' learned forecast
    (:mod:`casadi_gpc.estimation.walls_forecast`) read it."""
    if n < 3:
        raise ValueError(f"a wall scan needs at least 3 sectors, got {n}")
    rows = segments_near(np.asarray(rows, dtype=float).reshape(-1, 4), x, y, range_m)
    if not len(rows):
        return [float(range_m)] * n
    return wall_scans(rows, np.array([x], dtype=float), np.array([y], dtype=float),
                      np.array([math.cos(heading)]), np.array([math.sin(heading)]), n, range_m)[0].tolist()


def wall_scans(rows: np.ndarray, x: np.ndarray, y: np.ndarray, cos_h: np.ndarray, sin_h: np.ndarray, n: int,
               range_m: float) -> np.ndarray:
    """:func:`wall_scan` from ``p`` points at once, ``(p, n)``: the points ``(x, y)`` and their
    headings' cosines and sines (``(p,)`` each). The same numbers as one point at a time (the
    same operations element by element; a segment out of range lowers no sector below the cap,
    so none is left out here)."""
    rows = np.asarray(rows, dtype=float).reshape(-1, 4)
    if not len(rows):
        return np.full((len(x), n), float(range_m))
    c, s = cos_h[:, None], sin_h[:, None]                                         # (p, 1)
    ax, ay = rows[:, 0] - x[:, None], rows[:, 1] - y[:, None]                     # (p, m)
    bx, by = rows[:, 2] - x[:, None], rows[:, 3] - y[:, None]
    # the segments in each point's frame: a + t d
    a = np.stack([c * ax + s * ay, -s * ax + c * ay], axis=-1)[:, :, None, :]    # (p, m, 1, 2)
    b = np.stack([c * bx + s * by, -s * bx + c * by], axis=-1)[:, :, None, :]
    d = b - a
    u0, u1 = _edges(n)                                                            # (n, 2)
    shape = (len(x), len(rows), n)
    lo, hi, empty = np.zeros(shape), np.ones(shape), np.zeros(shape, dtype=bool)
    # left of the first edge: cross(u0, a + t d) >= 0; right of the second: cross(a + t d, u1) >= 0
    for g0, g1 in ((u0[:, 0] * a[..., 1] - u0[:, 1] * a[..., 0], u0[:, 0] * d[..., 1] - u0[:, 1] * d[..., 0]),
                   (a[..., 0] * u1[:, 1] - a[..., 1] * u1[:, 0], d[..., 0] * u1[:, 1] - d[..., 1] * u1[:, 0])):
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = -g0 / g1
        lo = np.where(g1 > 0, np.maximum(lo, bound), lo)
        hi = np.where(g1 < 0, np.minimum(hi, bound), hi)
        empty |= (g1 == 0) & (g0 < 0)
    dd = np.maximum((d * d).sum(-1), 1e-18)                                       # (p, m, 1)
    foot = -(a * d).sum(-1) / dd
    t = np.clip(foot, lo, hi)
    dist = np.hypot(a[..., 0] + t * d[..., 0], a[..., 1] + t * d[..., 1])
    dist[empty | (lo > hi)] = np.inf
    return np.minimum(dist.min(axis=1), range_m)
