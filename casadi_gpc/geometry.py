"""Points and line segments in the plane, once for everyone (numpy; the wall scan compiled with
numba): the distance from a point to a wall or a path, whether a straight move crosses a wall,
and the walls as a range sensor sees them. The robot's side
(the planner's wall slots and guesses) and the world (walls, sensors, path measures) both use
these."""
from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numba import njit

__all__ = ["nearest_on_segments", "distance_to_segments_m", "segments_cross", "segment_rows", "straight_runs",
           "walls_reach_m",
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


@lru_cache(maxsize=4)
def straight_runs(walls: tuple) -> tuple:
    """``walls`` (polylines of ``(x, y)`` points, as tuples) with every point that a straight run goes
    on through left out: the same walls, each straight stretch one segment however many pieces it
    was drawn in (a point where the run turns, by more than 1e-9 rad, or turns back, is kept). What
    the planner fills its wall slots with (:func:`casadi_gpc.problem.selection.select_walls`): each
    slot a segment, a straight wall drawn in 0.25 m pieces filled its six slots with 1.5 m of wall,
    and each of its joints counted as two walls (2026-12-02)."""
    out = []
    for pts in walls:
        kept = [pts[0]]
        for b, c in zip(pts[1:-1], pts[2:]):
            a = kept[-1]
            ux, uy, vx, vy = b[0] - a[0], b[1] - a[1], c[0] - b[0], c[1] - b[1]
            if not (abs(ux * vy - uy * vx) <= 1e-9 * math.hypot(ux, uy) * math.hypot(vx, vy) and ux * vx + uy * vy > 0):
                kept.append(b)
        kept.append(pts[-1])
        out.append(tuple(kept))
    return tuple(out)


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
    same operations on the same floats, compiled; a segment out of range lowers no sector below
    the cap, so none is left out here)."""
    rows = np.ascontiguousarray(rows, dtype=float).reshape(-1, 4)
    u0, u1 = _edges(n)
    out = np.empty((len(x), n))
    _scan_kernel(rows, np.ascontiguousarray(x, dtype=float), np.ascontiguousarray(y, dtype=float),
                 np.ascontiguousarray(cos_h, dtype=float), np.ascontiguousarray(sin_h, dtype=float),
                 np.ascontiguousarray(u0), np.ascontiguousarray(u1), float(range_m), out)
    return out


# compiled at import (a signature), never inside a decision
@njit("void(float64[:, ::1], float64[::1], float64[::1], float64[::1], float64[::1], float64[:, ::1], float64[:, ::1], "
      "float64, float64[:, ::1])", cache=True, error_model="numpy")
def _scan_kernel(rows, x, y, cos_h, sin_h, u0, u1, range_m, out):  # pragma: no cover - compiled
    """The scan of every point (:func:`wall_scans`), element by element in the order numpy's
    array form took them (division by zero as IEEE: ``error_model="numpy"``)."""
    for p in range(x.shape[0]):
        c, s = cos_h[p], sin_h[p]
        for k in range(u0.shape[0]):
            out[p, k] = np.inf
        for m in range(rows.shape[0]):
            ax0, ay0 = rows[m, 0] - x[p], rows[m, 1] - y[p]
            bx0, by0 = rows[m, 2] - x[p], rows[m, 3] - y[p]
            a0, a1 = c * ax0 + s * ay0, -s * ax0 + c * ay0
            b0, b1 = c * bx0 + s * by0, -s * bx0 + c * by0
            d0, d1 = b0 - a0, b1 - a1
            dd = max(d0 * d0 + d1 * d1, 1e-18)
            foot = -(a0 * d0 + a1 * d1) / dd
            for k in range(u0.shape[0]):
                lo, hi, empty = 0.0, 1.0, False
                # left of the first edge: cross(u0, a + t d) >= 0; right of the second: cross(a + t d, u1) >= 0
                for e in range(2):
                    if e == 0:
                        g0 = u0[k, 0] * a1 - u0[k, 1] * a0
                        g1 = u0[k, 0] * d1 - u0[k, 1] * d0
                    else:
                        g0 = a0 * u1[k, 1] - a1 * u1[k, 0]
                        g1 = d0 * u1[k, 1] - d1 * u1[k, 0]
                    bound = -g0 / g1
                    if g1 > 0:
                        lo = max(lo, bound)
                    if g1 < 0:
                        hi = min(hi, bound)
                    if g1 == 0 and g0 < 0:
                        empty = True
                if empty or lo > hi:
                    continue
                t = min(max(foot, lo), hi)
                dist = np.hypot(a0 + t * d0, a1 + t * d1)
                if dist < out[p, k]:
                    out[p, k] = dist
        for k in range(u0.shape[0]):
            out[p, k] = min(out[p, k], range_m)
