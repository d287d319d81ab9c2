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
           "a_wall_within", "segments_near", "segment_candidates", "map_segment_rows", "wall_scan", "wall_scans",
           "GRID_MIN_SEGMENTS"]


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


_MAPS: dict = {}  # id(walls) -> (walls, kept alive; its segment rows; its straight runs' rows, or None)
_MAPS_KEPT = 4


def map_segment_rows(walls: tuple, straight: bool = False) -> np.ndarray:
    """:func:`segment_rows` of ``walls`` (an observation's tuple of polylines), or of their
    :func:`straight_runs` with ``straight``, read-only, kept for the last few walls objects given
    (by identity: a map is made into rows once, not at every decision, 20 000 segments took
    milliseconds a decision): the one array of a map that the deployed policy, the check, the
    planner and the walkers' forecast read, and so one grid (:func:`segment_candidates`)."""
    kept = _MAPS.get(id(walls))
    if kept is None or kept[0] is not walls:
        rows = segment_rows(walls).copy()
        rows.flags.writeable = False
        if len(_MAPS) >= _MAPS_KEPT:
            _MAPS.pop(next(iter(_MAPS)), None)
        kept = _MAPS[id(walls)] = (walls, rows, None)  # one assignment: a thread reads an entry whole
    if straight and kept[2] is None:  # (made when first asked: straight_runs hashes the walls, tuples all through)
        runs = segment_rows(straight_runs(walls)).copy()
        runs.flags.writeable = False
        kept = _MAPS[id(walls)] = (walls, kept[1], runs)
    return kept[2] if straight else kept[1]


def a_wall_within(walls, xy, reach_m: float) -> bool:
    """Whether a segment of ``walls`` (polylines of ``(x, y)`` points) comes within ``reach_m``
    of the point ``xy`` (the planner's test of :func:`walls_reach_m`; the check takes the
    segments themselves, :func:`casadi_gpc.safety.walls.wall_segments_within`). A large map is
    read through its grid: the same segments measured the same way."""
    s = map_segment_rows(walls) if type(walls) is tuple else segment_rows(walls)
    idx = segment_candidates(s, float(xy[0]), float(xy[1]), reach_m)
    if idx is not None:
        s = s[idx]
    return bool(len(s)) and bool((distance_to_segments_m(np.asarray(xy, dtype=float), s[:, :2], s[:, 2:])
                                  <= reach_m).any())


GRID_MIN_SEGMENTS = 256
"""From this many segments on, a read-only array of segment rows is indexed by a grid once
(:func:`segment_candidates`) and a query measures only the segments of the cells it touches:
below it, measuring all of them costs less than the index's lookup."""
GRID_CELL_M = 2.0
"""The grid's cell (m): a query within a wall scan's 4 m reads some 25 cells."""
_GRIDS: dict = {}  # (data address, shape, strides) -> (the array, kept alive; its grid)


def segment_candidates(rows: np.ndarray, x: float, y: float, reach_m: float) -> np.ndarray | None:
    """The indices, ascending, of the segment rows (``(n, 4)``, ``(ax, ay, bx, by)``) whose
    bounding box meets the square of half side ``reach_m`` round ``(x, y)``: every segment within
    ``reach_m`` of the point among them. None (measure them all) for fewer than
    :data:`GRID_MIN_SEGMENTS` rows, or rows that can still change (a writeable array): the grid
    is built once per read-only array, on its first query, and kept while that array is used
    (a map of 20 000 segments queried at a decision's pace: docs/buildings.md, "Maps of any
    size")."""
    if len(rows) < GRID_MIN_SEGMENTS or rows.flags.writeable or not (
            math.isfinite(reach_m) and reach_m >= 0 and math.isfinite(x) and math.isfinite(y)):
        return None  # (a NaN point, a predicted path that failed, is measured against all: NaN as before)
    owner = rows  # the array that owns the memory: read-only too, or the rows could change under the grid
    while isinstance(owner.base, np.ndarray):
        owner = owner.base
    if owner.flags.writeable:
        return None
    key = (rows.__array_interface__["data"][0], rows.shape, rows.strides)
    hit = _GRIDS.get(key)  # the owner kept alive with its grid: no other array can take its address meanwhile
    if hit is None or hit[0] is not owner:
        if len(_GRIDS) >= 8:
            _GRIDS.pop(next(iter(_GRIDS)))
        hit = _GRIDS[key] = (owner, _build_grid(rows))
    lo_x, lo_y, c, nx, ny, offsets, members, mark = hit[1]
    # a cell more on each side: the cells were numbered by numpy's floor division, these by math.floor
    i0, i1 = math.floor((x - reach_m - lo_x) / c) - 1, math.floor((x + reach_m - lo_x) / c) + 1
    j0, j1 = math.floor((y - reach_m - lo_y) / c) - 1, math.floor((y + reach_m - lo_y) / c) + 1
    return _grid_query(offsets, members, nx, ny, max(i0, 0), min(i1, nx - 1), max(j0, 0), min(j1, ny - 1), mark)


def _build_grid(rows: np.ndarray) -> tuple:
    """Each segment listed in every cell its bounding box meets (compressed rows: ``offsets``,
    ``members``, each cell's ascending), with the grid's origin, cell and size. The cell is
    :data:`GRID_CELL_M`, doubled until the grid and its listings hold at most 64 entries a segment
    (a stray point kilometres off, or a long diagonal wall, would make millions of 2 m cells)."""
    xs, ys = rows[:, 0::2], rows[:, 1::2]
    lo_x, lo_y = float(xs.min()), float(ys.min())
    c, limit = GRID_CELL_M, 64 * len(rows) + 4096
    while True:
        nx, ny = int((xs.max() - lo_x) // c) + 1, int((ys.max() - lo_y) // c) + 1
        i0, i1 = ((xs.min(1) - lo_x) // c).astype(np.int64), ((xs.max(1) - lo_x) // c).astype(np.int64)
        j0, j1 = ((ys.min(1) - lo_y) // c).astype(np.int64), ((ys.max(1) - lo_y) // c).astype(np.int64)
        if nx * ny <= limit and int(((i1 - i0 + 1) * (j1 - j0 + 1)).sum()) <= limit:
            break
        c *= 2.0
    offsets, members = _grid_fill(i0, i1, j0, j1, ny, nx * ny)
    return lo_x, lo_y, c, nx, ny, offsets, members, np.zeros(len(rows), dtype=np.uint8)


@njit("Tuple((int64[::1], int64[::1]))(int64[::1], int64[::1], int64[::1], int64[::1], int64, int64)", cache=True)
def _grid_fill(i0, i1, j0, j1, ny, cells):  # pragma: no cover - compiled
    """The compressed listing of :func:`_build_grid`: segment ``m`` in cells ``[i0[m], i1[m]] x [j0[m], j1[m]]``."""
    counts = np.zeros(cells + 1, dtype=np.int64)
    for m in range(i0.shape[0]):
        for i in range(i0[m], i1[m] + 1):
            for j in range(j0[m], j1[m] + 1):
                counts[i * ny + j + 1] += 1
    offsets = np.cumsum(counts)
    members = np.empty(offsets[-1], dtype=np.int64)
    fill = offsets[:-1].copy()
    for m in range(i0.shape[0]):
        for i in range(i0[m], i1[m] + 1):
            for j in range(j0[m], j1[m] + 1):
                cell = i * ny + j
                members[fill[cell]] = m
                fill[cell] += 1
    return offsets, members


# compiled at import (signatures), never inside a decision
@njit("int64[::1](int64[::1], int64[::1], int64, int64, int64, int64, int64, int64, uint8[::1])", cache=True)
def _grid_query(offsets, members, nx, ny, i0, i1, j0, j1, mark):  # pragma: no cover - compiled
    """The members of the cells ``[i0, i1] x [j0, j1]``, each once, ascending (``mark``: zeros,
    left zeros)."""
    found = []
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            cell = i * ny + j
            for k in range(offsets[cell], offsets[cell + 1]):
                m = members[k]
                if mark[m] == 0:
                    mark[m] = 1
                    found.append(m)
    out = np.empty(len(found), dtype=np.int64)
    for k in range(len(found)):
        out[k] = found[k]
        mark[found[k]] = 0
    return np.sort(out)


def segments_near(rows: np.ndarray, x: float, y: float, reach_m: float) -> np.ndarray:
    """The rows of ``rows`` (:func:`segment_rows`) that come within ``reach_m`` of the
    point ``(x, y)``, in their order. A large read-only array is read through its grid
    (:func:`segment_candidates`): the same rows, measured by the same operations."""
    if not len(rows):
        return rows
    idx = segment_candidates(rows, x, y, reach_m)
    if idx is not None:
        rows = rows[idx]
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
    the cap, so none needs leaving out, and those a large map's grid leaves out, farther than the
    range from every point, change nothing)."""
    rows = np.ascontiguousarray(rows, dtype=float).reshape(-1, 4)
    if len(x):  # a large map: the segments of the grid's cells round the points alone (none farther lowers a sector)
        lo, hi = (float(np.min(x)), float(np.min(y))), (float(np.max(x)), float(np.max(y)))
        idx = segment_candidates(rows, (lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2,
                                 max(hi[0] - lo[0], hi[1] - lo[1]) / 2 + range_m)
        if idx is not None:
            rows = rows[idx]
    if not rows.flags.writeable:  # the kernel's signature takes a writeable array: a small read-only map copied
        rows = rows.copy()
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
