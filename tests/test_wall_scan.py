"""The walls as the network reads them (nn_export/runtime/wall_scan.py, the set-walls layout):
the scan against an independent dense sampling of the segments and against distances worked
out by hand, the layout's mirror map against the mirrored world, the features' invariance under
a change of world frame, the labeller with the planner's wall slots, and the policy's hand-over
to a walls network exactly where a wall is within the scan's range."""
from __future__ import annotations

import math

import numpy as np
import pytest

from casadi_gpc.config import preset
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotState
from nn_export.runtime.features import compute_features, mirror_features
from nn_export.runtime.layouts import layout_for, layout_from_dict
from nn_export.runtime.situation import Situation, TrackEstimate, reference_poses
from nn_export.runtime.wall_scan import WALL_SCAN_RANGE_M, WALL_SECTORS, wall_scan, wall_segment_rows

CFG = preset("improved")
LAY = layout_for("set-walls", CFG.horizon)
CORRIDOR = (((-10.0, 1.25), (20.0, 1.25)), ((-10.0, -1.25), (20.0, -1.25)))


def _sampled_scan(rows, x, y, heading, n, range_m, samples=40001):
    """The scan by brute force: many points along every segment, each put in its sector."""
    out = np.full(n, float(range_m))
    width = 2.0 * math.pi / n
    for ax, ay, bx, by in rows:
        t = np.linspace(0.0, 1.0, samples)
        px, py = ax + t * (bx - ax) - x, ay + t * (by - ay) - y
        lx, ly = math.cos(heading) * px + math.sin(heading) * py, -math.sin(heading) * px + math.cos(heading) * py
        k = np.floor(np.mod(np.arctan2(ly, lx) + width / 2, 2 * math.pi) / width).astype(int) % n
        r = np.hypot(lx, ly)
        np.minimum.at(out, k, r)
    return np.minimum(out, range_m)


def test_scan_matches_a_dense_sampling_of_random_walls():
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(25):
        rows = rng.uniform(-4.5, 4.5, (int(rng.integers(1, 5)), 4))
        x, y, h = rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-math.pi, math.pi)
        got = np.array(wall_scan(rows, x, y, h))
        want = _sampled_scan(rows, x, y, h, WALL_SECTORS, WALL_SCAN_RANGE_M)
        assert np.all(got <= want + 1e-9)  # exact minimum: never above a sampled point's distance
        worst = max(worst, float(np.max(want - got)))
    assert worst < 2e-3  # and the sampling (0.2 mm spacing on 9 m segments) comes within its step


def test_scan_in_a_corridor_by_hand():
    rows = wall_segment_rows(CORRIDOR)
    scan = np.array(wall_scan(rows, 0.0, 0.0, 0.0))
    width = 2 * math.pi / WALL_SECTORS
    for k, d in enumerate(scan):
        # the nearest wall point of sector k: the perpendicular foot (sector 6 and 18), else the
        # sector's edge nearest the perpendicular, at 1.25 / |sin(edge)|
        centre = k * width
        edges = (centre - width / 2, centre + width / 2)
        if k in (6, 18):
            want = 1.25
        else:
            want = min(1.25 / abs(math.sin(e)) if abs(math.sin(e)) > 1e-12 else math.inf for e in edges)
        assert d == pytest.approx(min(want, WALL_SCAN_RANGE_M), abs=1e-12), k
    # turned by one sector to the left, the scan turns one sector the other way
    turned = np.array(wall_scan(rows, 0.0, 0.0, width))
    assert np.allclose(turned, np.roll(scan, -1), atol=1e-12)
    # no wall within range: every sector reads the range
    assert wall_scan(rows, 0.0, 6.0, 0.3) == [WALL_SCAN_RANGE_M] * WALL_SECTORS


def test_a_door_post_between_two_directions_is_seen_at_its_distance():
    # a wall end 2 m ahead and 0.26 m to the left: it lies inside sector 0 (+-7.5 degrees)
    rows = wall_segment_rows([((2.0, 0.26), (2.0, 5.0))])
    scan = wall_scan(rows, 0.0, 0.0, 0.0)
    assert scan[0] == pytest.approx(math.hypot(2.0, 0.26), abs=1e-12)


def test_layout_names_round_trip_and_mirror_permutes_the_sectors():
    assert LAY.size == layout_for("set", CFG.horizon).size + WALL_SECTORS
    assert LAY.feature_names[-WALL_SECTORS:] == tuple(f"wall_{k}_m" for k in range(WALL_SECTORS))
    assert layout_from_dict(LAY.to_dict()) == LAY
    assert layout_for("set", CFG.horizon).to_dict().get("wall_sectors") is None  # the set layout as it was


def _track(i, state, std=0.2):
    H = CFG.horizon
    xy = np.asarray(state[:2], dtype=float)
    return TrackEstimate(i, 0.3, np.asarray(state, dtype=float), np.eye(5) * 1e-3, np.tile(xy, (H, 1)),
                         np.tile(np.eye(2) * std ** 2, (H, 1, 1)))


def _situation(walls=CORRIDOR, heading=0.1, y=0.3):
    T = CFG.sample_time_s
    path = ReferencePath((-2.0, 0.0), 0.0, (Segment.line(20.0),), 0.4)
    return Situation(RobotState(0.0, y, heading, 0.3, 0.35), reference_poses(path, 2.1, T, CFG.horizon), T, 0.4,
                     (_track(1, [2.5, -0.4, 0.4, math.pi, 0.0]),), (), walls=walls)


def test_features_of_the_mirrored_world_are_the_mirrored_features():
    sit = _situation(walls=CORRIDOR + (((1.5, 1.25), (1.5, 0.4)),))
    f = compute_features(LAY, sit)
    m = compute_features(LAY, sit.mirrored())
    assert np.allclose(mirror_features(LAY, f), m, atol=1e-9)
    scan = f[-WALL_SECTORS:]
    assert scan.min() < 1.25 and scan.max() == WALL_SCAN_RANGE_M  # the walls are read


def test_features_do_not_depend_on_the_world_frame():
    sit = _situation(walls=CORRIDOR + (((1.5, 1.25), (1.5, 0.4)),))
    f = compute_features(LAY, sit)
    g = compute_features(LAY, sit.transformed(1.1, (3.0, -2.0)))
    assert np.allclose(f, g, atol=1e-9)
    no_walls = compute_features(LAY, _situation(walls=()))
    assert np.all(no_walls[-WALL_SECTORS:] == WALL_SCAN_RANGE_M)
    assert np.array_equal(no_walls[:-WALL_SECTORS], compute_features(layout_for("set", CFG.horizon),
                                                                       _situation(walls=())))


def test_the_labeller_plans_with_the_walls_and_is_mirror_equivariant():
    from nn_export.training.labels import Labeller
    sit = _situation(walls=CORRIDOR, y=0.6)
    with pytest.raises(ValueError, match="wall slots"):
        Labeller(CFG).label(sit)
    lab = Labeller(CFG.for_walls(True), fit_slots=False)  # the full NLP: the one the planner's wall tests compile
    with_walls, without = lab.label(sit), lab.label(_situation(walls=(), y=0.6))
    assert with_walls.converged and without.converged
    # the wall 0.65 m to the left changes the answer (the planner keeps its margin from it)
    assert np.max(np.abs(with_walls.plan_wheels_mps - without.plan_wheels_mps)) > 1e-3
    assert lab.mirror_check(sit, with_walls) < 1e-6


def test_the_labeller_packs_the_planner_s_margin_near_walls():
    """A situation in a corridor: the labeller's parameters are the planner's
    (:func:`planner_parameters` with the robot's reach, the desired poses as its predicted
    path), the margin near walls in them; far from any wall, the open margin."""
    from casadi_gpc.geometry import walls_reach_m
    from casadi_gpc.problem.selection import planner_parameters
    from nn_export.training.labels import Labeller
    cfg = CFG.for_walls(True)
    lab = Labeller(cfg, fit_slots=False)
    reach = walls_reach_m(lab.robot, cfg.horizon * cfg.sample_time_s)
    far = tuple(tuple((x, y + 12.0) for x, y in w) for w in CORRIDOR)  # the same corridor, out of reach
    for walls, margin in ((CORRIDOR, [cfg.walls_margin_m, cfg.walls_sigmas]),
                          (far, [cfg.clearance_margin_m, cfg.uncertainty_sigmas])):
        sit = _situation(walls=walls, y=0.6)
        p = lab.parameters(sit)
        planner, sel = planner_parameters(lab.layout, sit.robot.as_array(), sit.ref_poses, sit.forecasts(),
                                          sit.statics, cfg, None, walls, reach)
        np.testing.assert_array_equal(p, planner)
        np.testing.assert_array_equal(lab.layout.unpack(p)["margin"], margin)
        assert sel.near_walls is (walls is CORRIDOR)


def test_the_policy_hands_decisions_to_the_walls_network_exactly_near_walls(tmp_path):
    from casadi_gpc.types import Observation, ObstacleMeasurement
    from nn_export import OnnxPolicy
    from synthetic_models import tracker_model
    main = tracker_model(tmp_path / "main.onnx", "improved")
    walls = tracker_model(tmp_path / "walls.onnx", "improved", layout_name="set-walls", decision_passes="1",
                          extra_weights={"wall_6_m": (0.05, -0.05)})
    both = OnnxPolicy(main, preset="improved", walls_model=walls)
    alone = OnnxPolicy(walls, preset="improved")
    only_main = OnnxPolicy(main, preset="improved")
    T = CFG.sample_time_s
    path = ReferencePath((0.0, 0.0), 0.0, (Segment.line(30.0),), 0.4)
    answered = []
    for k in range(24):  # the robot drives along +x; a wall ends at x = 5, 1 m to its left
        obs = Observation(k * T, RobotState(0.5 * k, 0.0, 0.0, 0.3, 0.3), path,
                          (ObstacleMeasurement(0, (12.0, 0.5), 0.3),), walls=(((-20.0, 1.0), (5.0, 1.0)),))
        d, a, m = both.decide(obs), alone.decide(obs), only_main.decide(obs)
        near = math.hypot(max(0.5 * k - 5.0, 0.0), 1.0) <= WALL_SCAN_RANGE_M
        want = a if near else m
        assert (d.v_right_mps, d.v_left_mps) == (want.v_right_mps, want.v_left_mps)
        answered.append(near)
    assert both.counters["walls_network"] == sum(answered) and 0 < sum(answered) < 24
    # it reads the scan: beside the wall (1 m in sector 6, not 4 m) the right wheel is 0.15 m/s slower
    alone.reset()
    obs = Observation(0.0, RobotState(0.0, 0.0, 0.0, 0.3, 0.3), path, (), walls=(((-20.0, 1.0), (5.0, 1.0)),))
    far = Observation(0.0, RobotState(0.0, 0.0, 0.0, 0.3, 0.3), path, (), walls=(((-20.0, 9.0), (5.0, 9.0)),))
    a, b = alone.decide(obs), (alone.reset(), alone.decide(far))[1]
    assert a.v_right_mps - b.v_right_mps == pytest.approx(-0.15, abs=1e-5)
    assert a.v_left_mps - b.v_left_mps == pytest.approx(0.15, abs=1e-5)
    assert alone.rollout() is not None
    with pytest.raises(ValueError, match="read walls"):
        OnnxPolicy(main, preset="improved", walls_model=tracker_model(tmp_path / "set.onnx", "improved",
                                                                      layout_name="set", decision_passes="1"))


def test_a_static_disc_as_wall_pieces_is_the_polygon_round_it():
    """``static_wall_rows``: each disc a closed regular octagon whose every edge touches it, so
    that a scan sees it no farther than the disc and no nearer than the octagon's corners
    allow (radius / cos(pi / 8))."""
    from casadi_gpc.geometry import distance_to_segments_m
    from casadi_gpc.types import StaticObstacle
    from nn_export.runtime.wall_scan import DISC_SIDES, static_wall_rows
    rng = np.random.default_rng(8)
    discs = tuple(StaticObstacle(tuple(rng.uniform(-3, 3, 2)), float(rng.uniform(0.1, 0.5))) for _ in range(5))
    rows = static_wall_rows(discs)
    assert rows.shape == (DISC_SIDES * len(discs), 4) and static_wall_rows(()).shape == (0, 4)
    corner = 1.0 / math.cos(math.pi / DISC_SIDES)
    for j, d in enumerate(discs):
        own = rows[j * DISC_SIDES:(j + 1) * DISC_SIDES]
        c = np.asarray(d.position_m)
        assert np.allclose(own[1:, :2], own[:-1, 2:], atol=0) and np.allclose(own[0, :2], own[-1, 2:], atol=1e-12)
        gaps = [distance_to_segments_m(c, r[None, :2], r[None, 2:])[0] for r in own]  # each edge touches the disc
        assert np.allclose(gaps, d.radius_m, atol=1e-12)
        for _ in range(10):  # seen from outside: between the disc's own distance and the corners'
            p = c + rng.uniform(1.0, 3.0) * np.array([math.cos(a := rng.uniform(0, 2 * math.pi)), math.sin(a)])
            near = min(wall_scan(own, *p, rng.uniform(-3, 3), range_m=10.0))
            true = float(np.hypot(*(p - c)))
            assert true - d.radius_m * corner - 1e-12 <= near <= true - d.radius_m + 1e-12


def test_statics_as_walls_give_the_walls_network_the_octagons_and_nothing_else(tmp_path):
    """``OnnxPolicy(statics_as_walls=True)``, the default: where the walls network answers, its decision is the
    one it gives with each static disc's octagon among the walls and no static obstacle (and so
    is its roll-out); where it does not (no wall in range), the decision is the option's off."""
    from casadi_gpc.types import Observation, ObstacleMeasurement, StaticObstacle
    from nn_export import OnnxPolicy
    from nn_export.runtime.wall_scan import static_wall_rows
    from synthetic_models import tracker_model
    main = tracker_model(tmp_path / "main.onnx", "improved")
    walls = tracker_model(tmp_path / "walls.onnx", "improved", layout_name="set-walls", decision_passes="1",
                          extra_weights={"wall_0_m": (0.05, -0.05), "sta1_x_m": (0.2, 0.1)})
    on = OnnxPolicy(main, preset="improved", walls_model=walls)  # the default
    off = OnnxPolicy(main, preset="improved", walls_model=walls, statics_as_walls=False)
    T = CFG.sample_time_s
    path = ReferencePath((0.0, 0.0), 0.0, (Segment.line(30.0),), 0.4)
    pillar = (StaticObstacle((3.0, 0.2), 0.3),)
    octagon = [tuple(map(tuple, r.reshape(2, 2))) for r in static_wall_rows(pillar)]
    differ = answered = 0
    for k in range(12):
        for wall in ((((-20.0, 1.0), (20.0, 1.0)),), (((-20.0, 9.0), (20.0, 9.0)),)):  # near, then out of range
            mover = (ObstacleMeasurement(0, (8.0 - 0.3 * k, -0.4), 0.3),)
            obs = Observation(k * T, RobotState(0.2 * k, 0.0, 0.0, 0.3, 0.3), path, mover, pillar, walls=wall)
            seen = Observation(k * T, RobotState(0.2 * k, 0.0, 0.0, 0.3, 0.3), path, mover, (),
                               walls=wall + tuple(octagon))
            for p in (on, off):
                p.reset()
            d, o = on.decide(obs), off.decide(obs)
            ref = OnnxPolicy(main, preset="improved", walls_model=walls, statics_as_walls=False)
            r = ref.decide(seen)
            near = wall[0][0][1] == 1.0
            want = r if near else o
            assert (d.v_right_mps, d.v_left_mps) == (want.v_right_mps, want.v_left_mps)
            answered += d.reason == "one pass: walls network"
            if near:
                differ += (d.v_right_mps, d.v_left_mps) != (o.v_right_mps, o.v_left_mps)
                np.testing.assert_array_equal(on.rollout()[0], ref.rollout()[0])
    assert answered == 12 and differ >= 8  # near the wall only; the scan and the slots read differently (10)


def test_the_samples_give_the_walls_network_pillars_as_the_deployed_policy_does():
    """A ``set-walls`` sample in a situation with walls reads each static disc as the policy
    gives it (``OnnxPolicy(statics_as_walls=True)``): the octagon round it in the scan, no
    static slot, the same features to the bit as the situation with the octagon among its
    walls and no static obstacle; without walls the disc stays in its slot (the scan is
    empty then, and the walls network never answers there)."""
    from dataclasses import replace

    from casadi_gpc.types import StaticObstacle
    from nn_export.runtime.wall_scan import scan_rows, static_wall_rows
    pillar = (StaticObstacle((1.2, -0.3), 0.25),)
    octagon = tuple(tuple(map(tuple, r.reshape(2, 2))) for r in static_wall_rows(pillar))
    with_pillar = replace(_situation(), statics=pillar)
    as_walls = replace(_situation(walls=CORRIDOR + octagon), statics=())
    f = compute_features(LAY, with_pillar)
    assert np.array_equal(f, compute_features(LAY, as_walls))
    assert not np.array_equal(f, compute_features(LAY, _situation()))  # the pillar is read, in the scan
    assert f[LAY.feature_names.index("sta1_present")] == 0.0
    open_floor = replace(_situation(walls=()), statics=pillar)
    g = compute_features(LAY, open_floor)
    assert g[LAY.feature_names.index("sta1_present")] == 1.0 and np.all(g[-WALL_SECTORS:] == WALL_SCAN_RANGE_M)
    rows = wall_segment_rows(CORRIDOR)
    assert scan_rows(rows, ()) == (rows, ())
