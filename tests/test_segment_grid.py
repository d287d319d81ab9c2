"""The grid that large maps are read through (casadi_gpc.geometry.segment_candidates): the same
segments as measuring every one, in the same order, to the bit, for the wall scan's query
(segments_near, wall_scan) and the check's (wall_segments_within); and only for arrays that
cannot change under it."""
from __future__ import annotations

import math

import numpy as np
import pytest

from casadi_gpc.geometry import GRID_MIN_SEGMENTS, segment_candidates, segments_near, wall_scan
from casadi_gpc.safety.walls import wall_segments, wall_segments_within
from nn_export.runtime.wall_scan import map_rows


def _map(rng, n_walls: int) -> tuple:
    """Polylines of every kind: short pieces, long walls across many cells, axis-aligned ones on
    the cells' edges (multiples of the 2 m cell), zero-length pieces, far outliers."""
    walls = []
    for k in range(n_walls):
        kind = k % 5
        if kind == 0:
            x, y = rng.uniform(-30, 30, 2)
            pts = np.cumsum(rng.normal(0, 0.3, (rng.integers(2, 8), 2)), axis=0) + (x, y)
        elif kind == 1:
            pts = rng.uniform(-40, 40, (2, 2))
        elif kind == 2:
            v = float(2 * rng.integers(-10, 10))
            pts = np.array([[v, -20.0], [v, 20.0]]) if rng.random() < 0.5 else np.array([[-20.0, v], [20.0, v]])
        elif kind == 3:
            x, y = rng.uniform(-30, 30, 2)
            pts = np.array([[x, y], [x, y], [x + 0.5, y]])
        else:
            pts = rng.uniform(-5, 5, (3, 2)) + rng.choice([-1e3, 1e3], 2)
        walls.append(tuple((float(a), float(b)) for a, b in pts))
    return tuple(walls)


def _brute(rows, x, y, reach):
    writeable = rows.copy()  # a writeable array is never read through a grid
    return segments_near(writeable, x, y, reach)


@pytest.mark.parametrize("seed", range(6))
def test_a_large_map_gives_the_same_segments_through_its_grid(seed):
    rng = np.random.default_rng(seed)
    walls = _map(rng, 400)
    rows = map_rows(walls)
    assert len(rows) >= GRID_MIN_SEGMENTS and not rows.flags.writeable
    points = [tuple(rng.uniform(-35, 35, 2)) for _ in range(60)] + [(0.0, 0.0), (2.0, 4.0), (-6.0, 10.0), (1e3, 1e3)]
    used = 0
    for x, y in points:
        for reach in (0.0, 0.5, 1.85, 4.0, 8.8, 100.0):
            idx = segment_candidates(rows, x, y, reach)
            assert idx is not None
            used += len(idx) < len(rows)
            got, want = segments_near(rows, x, y, reach), _brute(rows, x, y, reach)
            assert got.shape == want.shape and np.array_equal(got.view(np.uint64), want.view(np.uint64))
            seg = wall_segments_within(walls, (x, y), reach)
            all_seg = wall_segments(walls)
            from casadi_gpc.safety.walls import point_segment_distance
            ref = all_seg[point_segment_distance(complex(x, y), all_seg[:, 0], all_seg[:, 1]) <= reach]
            assert np.array_equal(seg, ref)
        heading = float(rng.uniform(-math.pi, math.pi))
        scan = wall_scan(rows, x, y, heading, 24, 4.0)
        assert scan == wall_scan(rows.copy(), x, y, heading, 24, 4.0)  # the floats themselves
    assert used > len(points)  # the grid left segments out: it was read


def test_many_points_scanned_at_once_on_a_large_map_read_the_same_floats():
    from casadi_gpc.geometry import wall_scans
    rng = np.random.default_rng(11)
    rows = map_rows(_map(rng, 400))
    for spread in (0.5, 5.0, 30.0):
        x, y = rng.uniform(-spread, spread, 12), rng.uniform(-spread, spread, 12)
        h = rng.uniform(-math.pi, math.pi, 12)
        got = wall_scans(rows, x, y, np.cos(h), np.sin(h), 24, 4.0)
        assert np.array_equal(got.view(np.uint64), wall_scans(rows.copy(), x, y, np.cos(h), np.sin(h), 24, 4.0)
                              .view(np.uint64))
        assert (got < 4.0).any()  # walls in range: the scan measured some


def test_segments_at_exactly_the_reach_are_found():
    """Segments whose nearest point is exactly ``reach`` away, on the cells' edges: kept, as
    measuring all of them keeps them."""
    walls = tuple(((float(2 * k), 4.0), (float(2 * k), 10.0)) for k in range(-200, 200))
    rows = map_rows(walls)
    for x in (0.0, 2.0, 3.0, -7.999999999):
        for reach in (4.0, 2.0, 6.0):
            assert np.array_equal(segments_near(rows, x, 0.0, reach), _brute(rows, x, 0.0, reach))


def test_a_writeable_or_small_array_is_measured_whole():
    rng = np.random.default_rng(9)
    big = map_rows(_map(rng, 400))
    assert segment_candidates(big.copy(), 0.0, 0.0, 4.0) is None  # writeable: it could change under a grid
    assert segment_candidates(big, math.nan, 0.0, 4.0) is None and segment_candidates(big, 0.0, 0.0, math.inf) is None
    assert len(segments_near(big, math.nan, 0.0, 4.0)) == 0  # NaN is near nothing, as without a grid
    small = map_rows(_map(rng, 10))
    assert len(small) < GRID_MIN_SEGMENTS and segment_candidates(small, 0.0, 0.0, 4.0) is None
    view = np.asarray(big, dtype=float).reshape(-1, 4)  # a read-only view of a read-only map: its grid
    assert segment_candidates(view, 0.0, 0.0, 4.0) is not None
    base = big.copy()
    ro_view = base[:]
    ro_view.flags.writeable = False  # read-only, but its memory is not
    assert segment_candidates(ro_view, 0.0, 0.0, 4.0) is None


def _select_walls_measuring_all(x0, walls, config, path_xy):
    """select_walls as it was before the grid: every straight run measured."""
    from casadi_gpc.geometry import distance_to_segments_m, segment_rows, straight_runs
    segs = segment_rows(straight_runs(walls))
    pts = np.vstack([x0[:2], np.asarray(path_xy)[:, :2]])
    d = distance_to_segments_m(pts, segs[:, :2], segs[:, 2:]).min(axis=0)
    order = np.argsort(d, kind="stable")
    chosen = order[:config.max_walls]
    left_out = int(np.count_nonzero(d[order[config.max_walls:]] < config.relevance_range_m))
    return [tuple(segs[k]) for k in chosen], left_out


@pytest.mark.parametrize("seed", range(4))
def test_the_planner_s_wall_slots_and_reach_on_a_large_map_are_those_of_every_segment(seed):
    from casadi_gpc.config import preset
    from casadi_gpc.geometry import a_wall_within, distance_to_segments_m, segment_rows
    from casadi_gpc.problem.selection import select_walls
    cfg = preset("improved").with_overrides(max_walls=6)  # the slots a planner of a map with walls has
    rng = np.random.default_rng(100 + seed)
    walls = _map(rng, 400)
    sparse = tuple(w for k, w in enumerate(walls) if k % 5 == 2)  # a few long walls: fewer near than the slots
    for case in (walls, sparse):
        all_rows = segment_rows(case)
        for _ in range(40):
            x0 = np.array([*rng.uniform(-35, 35, 2), rng.uniform(-3, 3), 0.3, 0.3])
            path = x0[:2] + np.cumsum(rng.normal(0, 0.4, (12, 2)), axis=0)
            got, want = select_walls(x0, case, cfg, path), _select_walls_measuring_all(x0, case, cfg, path)
            assert got[1] == want[1] and len(got[0]) == len(want[0])
            assert all(np.array_equal(np.array(a), np.array(b)) for a, b in zip(got[0], want[0]))
            for reach in (1.0, 5.35, 30.0):
                brute = bool((distance_to_segments_m(x0[:2], all_rows[:, :2], all_rows[:, 2:]) <= reach).any())
                assert a_wall_within(case, x0[:2], reach) == brute


def test_the_planner_s_wall_slots_where_the_map_is_dense_and_where_the_near_walls_are_fewer_than_its_slots(
        monkeypatch):
    """A lattice of short walls, many within reach of any path (the grid's cells alone are
    measured), and three walls near the robot with the rest of the map 40 m off (fewer near than
    the slots: every segment is measured, and the far ones fill the slots as before)."""
    from casadi_gpc.config import preset
    from casadi_gpc.problem.selection import select_walls
    cfg = preset("improved").with_overrides(max_walls=6)
    lattice = tuple(((x, y), (x + 0.3, y + 0.1)) for x in np.arange(-15.0, 15.0, 0.5).tolist()
                    for y in np.arange(-15.0, 15.0, 0.5).tolist())
    far = tuple(((40.0 + 0.3 * k, 40.0), (40.2 + 0.3 * k, 40.5)) for k in range(400))
    sparse = (((1.0, 1.0), (1.5, 1.0)), ((-1.0, -2.0), (-1.0, -2.5)), ((3.0, 0.0), (3.0, 0.4))) + far
    import casadi_gpc.problem.selection as selection
    measured = []
    measure = selection.distance_to_segments_m
    monkeypatch.setattr(selection, "distance_to_segments_m",
                        lambda p, a, b: measured.append(len(a)) or measure(p, a, b))
    rng = np.random.default_rng(5)
    for case in (lattice, sparse):
        n = len(map_rows(case))
        assert n >= GRID_MIN_SEGMENTS
        for _ in range(30):
            x0 = np.array([*rng.uniform(-3, 3, 2), 0.0, 0.3, 0.3])
            path = x0[:2] + np.cumsum(rng.normal(0, 0.3, (12, 2)), axis=0)
            measured.clear()
            got = select_walls(x0, case, cfg, path)
            # the lattice: the cells round the path alone; the sparse map: those first, then every segment
            assert (max(measured) < n / 4) if case is lattice else (measured[-1] == n)
            want = _select_walls_measuring_all(x0, case, cfg, path)
            assert got[1] == want[1] and len(got[0]) == len(want[0]) == 6
            assert all(np.array_equal(np.array(a), np.array(b)) for a, b in zip(got[0], want[0]))


def test_an_observation_takes_a_map_found_valid_as_it_is_and_still_refuses_a_bad_one():
    """The observation checks its walls once per map object (tuples of floats cannot change), and
    every other object again: a bad map after a good one is refused."""
    from casadi_gpc.types import Observation, RobotState
    from casadi_gpc.reference import ReferencePath, Segment
    path = ReferencePath((0.0, 0.0), 0.0, (Segment.line(5.0),), 0.4)
    good = _map(np.random.default_rng(3), 300)
    a = Observation(0.0, RobotState(0.0, 0.0, 0.0, 0.0, 0.0), path, (), walls=good)
    b = Observation(0.5, RobotState(0.0, 0.0, 0.0, 0.0, 0.0), path, (), walls=good)
    assert a.walls is good and b.walls is good
    bad = good[:-1] + (((0.0, 0.0), (math.nan, 1.0)),)
    with pytest.raises(ValueError, match="not finite"):
        Observation(1.0, RobotState(0.0, 0.0, 0.0, 0.0, 0.0), path, (), walls=bad)
    listed = [list(map(list, w)) for w in good]  # lists: read into tuples, a new object
    c = Observation(1.5, RobotState(0.0, 0.0, 0.0, 0.0, 0.0), path, (), walls=listed)
    assert c.walls == good and c.walls is not good


def test_the_simulator_measures_every_wall_in_one_call_as_each_wall_measures_itself():
    """The world's side of a large map: the gaps to every wall at the collision check's instants in
    one call (``Episode._wall_gaps``) are each wall's own ``distance_m`` less the radius, to the bit."""
    from scenarios.loader import scenario_from_dict
    from scenarios.simulator import Episode
    rng = np.random.default_rng(21)
    from casadi_gpc.geometry import distance_to_segments_m
    walls = [w for w in _map(rng, 300) if all(a != b for a, b in zip(w[:-1], w[1:]))  # a file refuses zero length
             and distance_to_segments_m(np.zeros(2), np.array(w[:-1]), np.array(w[1:])).min() > 1.0]
    sc = scenario_from_dict({"name": "w", "duration_s": 10.0, "robot": {"position": [0.0, 0.0], "heading_deg": 0.0},
                             "reference": {"position": [0.0, 0.0], "heading_deg": 0.0, "speed_mps": 0.4,
                                           "segments": [{"line_m": 3.0}]},
                             "walls": [{"points": [list(p) for p in w]} for w in walls]})
    ep = Episode(sc, 0.5)
    xy = rng.uniform(-40, 40, (20, 2))
    want = np.stack([w.distance_m(xy) - sc.robot.radius_m for w in sc.walls], axis=-1)
    got = ep._wall_gaps(xy)
    assert got.shape == want.shape == (20, len(sc.walls)) and np.array_equal(got, want)


def test_a_query_of_a_large_map_is_several_times_faster_through_its_grid():
    """Timed in one run, the ratio asserted (the machines are shared): 10 002 segments of a
    building (two long walls, 2 500 small rooms up to 50 m off), a query within a scan's 4 m
    through the grid against the same query measuring every segment (about ten times, measured)."""
    import time
    rng = np.random.default_rng(3)
    walls = [((-5.0, s), (25.0, s)) for s in (-1.5, 1.5)]
    for _ in range(2500):
        cx, cy = float(rng.uniform(-50, 50)), float(rng.choice([-1, 1]) * rng.uniform(3, 50))
        walls.append(((cx, cy), (cx + 0.3, cy), (cx + 0.3, cy + 0.3), (cx, cy + 0.3), (cx, cy)))
    rows = map_rows(tuple(walls))
    whole = rows.copy()
    pts = rng.uniform(-30, 30, (200, 2)).tolist()
    segments_near(rows, 0.0, 0.0, 4.0)  # the grid built
    best = {}
    for _ in range(3):
        for name, r in (("grid", rows), ("all", whole)):
            t0 = time.perf_counter()
            for x, y in pts:
                segments_near(r, x, y, 4.0)
            best[name] = min(best.get(name, math.inf), time.perf_counter() - t0)
    assert best["all"] / best["grid"] > 3.0, best
