"""The one feature definition (nn_export.runtime: layouts, features): layouts, known answers, the absent
obstacle, the mirror map, identity of the dataset and deployed paths, and invariance to a
rotation and translation of the whole world."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from casadi_gpc.config import preset
from casadi_gpc.estimation.ekf import ObstacleEKF
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotState
from casadi_gpc.types import ObstacleMeasurement, Observation, StaticObstacle
from nn_export.runtime.features import compute_features, mirror_features
from nn_export.runtime.layouts import FEATURE_VERSION, layout_for, layout_from_dict
from nn_export.runtime.situation import Situation, TrackEstimate, reference_poses, track_estimate
from nn_export.runtime.tracker import SituationTracker
from nn_export.training.sampler import episode_tail, sample_situation, situation_from_tail

ANGLES = {"mov1_heading_rad", "mov2_heading_rad", "mov3_heading_rad"}


def assert_features_close(layout, a, b, atol):
    """Equal to ``atol``, angles in [0, 2 pi) compared on the circle."""
    a, b = np.asarray(a), np.asarray(b)
    d = np.abs(a - b)
    for i, n in enumerate(layout.feature_names):
        if n in ANGLES:
            d[..., i] = np.abs((a[..., i] - b[..., i] + math.pi) % (2 * math.pi) - math.pi)
    assert np.max(d) <= atol, (np.max(d), layout.feature_names[int(np.argmax(d.reshape(-1, layout.size).max(0)))])


def test_layout_sizes_and_names():
    paper = layout_for("paper", 6)
    assert paper.size == 17  # the paper's seventeen input neurons
    assert paper.feature_names[:2] == ("v_right_prev_mps", "v_left_prev_mps")
    assert paper.feature_names[-1] == "ref_speed_mps"
    assert layout_for("paper", 12).size == 23  # the curvature samples follow the horizon
    multi = layout_for("multi", 12)
    assert multi.size == 6 + 8 * 3 + 4 * 3 + 12
    assert sum(n.endswith("_present") for n in multi.feature_names) == 6
    assert len(set(multi.feature_names)) == multi.size
    d = multi.to_dict()
    assert d["version"] == FEATURE_VERSION and layout_from_dict(d) == multi
    with pytest.raises(ValueError, match="version"):
        layout_from_dict({**d, "version": FEATURE_VERSION + 1})
    with pytest.raises(ValueError, match="unknown feature layout"):
        layout_for("fancy", 6)


def _straight_situation(T=1.5, H=6):
    """Robot at (1, 2) heading north on a northbound line, reference 0.5 m ahead."""
    path = ReferencePath((1.0, 0.0), math.pi / 2, (Segment.line(30.0),), 0.4)
    ref = reference_poses(path, 2.5, T, H)  # reference point at (1, 2.5)
    robot = RobotState(1.0, 2.0, math.pi / 2, 0.3, 0.25)
    return Situation(robot, ref, T, 0.4)


def test_known_answer_straight_reference_and_absent_obstacle():
    lay = layout_for("paper", 6)
    rep = {}
    f = dict(zip(lay.feature_names, compute_features(lay, _straight_situation(), report=rep)))
    assert f["v_right_prev_mps"] == 0.3 and f["v_left_prev_mps"] == 0.25
    # first desired point: 0.5 m + one step (0.4 m/s * 1.5 s) straight ahead
    assert f["ref_x_m"] == pytest.approx(1.1, abs=1e-12)
    assert f["ref_y_m"] == pytest.approx(0.0, abs=1e-12)
    assert f["ref_heading_rad"] == pytest.approx(0.0, abs=1e-12)
    for k in range(1, 7):
        assert f[f"ref_curvature_{k}_1pm"] == pytest.approx(0.0, abs=1e-12)
    assert f["ref_speed_mps"] == pytest.approx(0.4, abs=1e-12)
    # the absent obstacle: standing, parked at the edge of the range behind the robot
    assert (f["mov1_x_m"], f["mov1_y_m"], f["mov1_speed_mps"], f["mov1_heading_rad"], f["mov1_turn_rad"]) == (
        -lay.range_m, 0.0, 0.0, math.pi, 0.0)
    assert rep == {}


def test_known_answer_arc_reference_and_path_end():
    lay = layout_for("paper", 6)
    T, R = 0.5, 3.0
    path = ReferencePath((0.0, 0.0), 0.0, (Segment.arc(R, math.pi), Segment.line(0.5)), 0.4)
    robot = RobotState(0.0, 0.0, 0.0, 0.4, 0.4)
    f = dict(zip(lay.feature_names, compute_features(lay, Situation(robot, reference_poses(path, 0.0, T, 6), T, 0.4))))
    a = 0.2 / R  # the angle of one step's arc
    assert f["ref_x_m"] == pytest.approx(R * math.sin(a), abs=1e-12)
    assert f["ref_y_m"] == pytest.approx(R * (1 - math.cos(a)), abs=1e-12)
    assert f["ref_heading_rad"] == pytest.approx(a, abs=1e-12)
    for k in range(1, 7):
        assert f[f"ref_curvature_{k}_1pm"] == pytest.approx(1 / R, abs=1e-9)
    assert f["ref_speed_mps"] == pytest.approx(0.4, abs=1e-9)
    # near the goal the desired points bunch up: no curvature there, and a lower mean speed
    s_end = path.length_m - 0.3
    f = dict(zip(lay.feature_names, compute_features(lay, Situation(robot, reference_poses(path, s_end, T, 6), T, 0.4))))
    assert f["ref_speed_mps"] == pytest.approx(0.3 / (6 * T), abs=1e-9)
    assert f["ref_curvature_6_1pm"] == 0.0


def test_known_answer_obstacle_in_local_frame():
    lay = layout_for("paper", 6)
    base = _straight_situation()
    # an obstacle 3 m ahead and 1 m to the right of the north-facing robot, heading west after
    # this step's turn of 0.05 rad (theta + dtheta = pi), i.e. pi/2 to the robot's left
    state = np.array([1.0 + 1.0, 2.0 + 3.0, 0.35, math.pi - 0.05, 0.05])
    tr = TrackEstimate(7, 0.3, state, np.eye(5) * 1e-4, np.zeros((6, 2)) + state[:2],
                       np.tile(np.eye(2) * 1e-4, (6, 1, 1)))
    f = dict(zip(lay.feature_names, compute_features(lay, replace(base, tracks=(tr,)))))
    assert f["mov1_x_m"] == pytest.approx(3.0, abs=1e-12)
    assert f["mov1_y_m"] == pytest.approx(-1.0, abs=1e-12)
    assert f["mov1_speed_mps"] == 0.35
    assert f["mov1_heading_rad"] == pytest.approx(math.pi / 2, abs=1e-12)  # theta(k+1) = theta + dtheta
    assert f["mov1_turn_rad"] == 0.05
    # farther than the range: absent, and counted
    far = replace(tr, state=state + np.array([0.0, 20.0, 0, 0, 0]), means_m=tr.means_m + [0.0, 20.0])
    rep = {}
    g = compute_features(lay, replace(base, tracks=(far,)), report=rep)
    assert g[lay.index("mov1_x_m")] == -lay.range_m and rep["out_of_range"] == 1
    # more obstacles than slots: the nearest is kept, the other counted
    rep = {}
    crowd = replace(base, tracks=(far, tr), statics=(StaticObstacle((0.0, 0.0), 0.2),))
    h = compute_features(lay, crowd, report=rep)
    assert h[lay.index("mov1_x_m")] == pytest.approx(3.0) and rep["out_of_range"] == 1 and rep["dropped_static"] == 1


def test_multi_layout_slots_flags_and_order():
    lay = layout_for("multi", 6)
    base = _straight_situation()
    near = np.array([1.0, 4.0, 0.2, 0.0, 0.0])
    far = np.array([1.0, 8.0, 0.1, 0.0, 0.0])
    mk = lambda s, i: TrackEstimate(i, 0.25 + 0.1 * i, s, np.eye(5) * 1e-3, np.tile(s[:2], (6, 1)),
                                    np.tile(np.eye(2) * 0.04, (6, 1, 1)))
    sit = replace(base, tracks=(mk(far, 1), mk(near, 0)), statics=(StaticObstacle((3.0, 2.0), 0.3),))
    f = dict(zip(lay.feature_names, compute_features(lay, sit)))
    assert f["mov1_present"] == 1 and f["mov1_x_m"] == pytest.approx(2.0) and f["mov1_radius_m"] == 0.25
    assert f["mov2_present"] == 1 and f["mov2_x_m"] == pytest.approx(6.0) and f["mov2_radius_m"] == pytest.approx(0.35)
    assert f["mov1_pos_std_m"] == pytest.approx(0.2)
    assert f["mov3_present"] == 0 and f["mov3_x_m"] == -lay.range_m and f["mov3_radius_m"] == 0
    assert f["sta1_present"] == 1 and f["sta1_x_m"] == pytest.approx(0.0) and f["sta1_y_m"] == pytest.approx(-2.0)
    assert f["sta2_present"] == 0 and f["sta2_x_m"] == -lay.range_m


@pytest.mark.parametrize("preset_name, layout_name", [("paper", "paper"), ("improved", "paper"), ("improved", "multi"),
                                                      ("improved", "set")])
def test_mirror_map_matches_the_mirrored_world(preset_name, layout_name):
    cfg = preset(preset_name)
    lay = layout_for(layout_name, cfg.horizon)
    rng = np.random.default_rng(11)
    for _ in range(60):
        sit = sample_situation(rng, cfg, layout_name)
        f = compute_features(lay, sit)
        assert_features_close(lay, compute_features(lay, sit.mirrored()), mirror_features(lay, f), 1e-9)
        assert_features_close(lay, mirror_features(lay, mirror_features(lay, f)), f, 1e-12)


def _replay_deployed(tail, cfg):
    """The deployed path: a fresh tracker fed the observation stream, sample by sample."""
    tracker = SituationTracker(cfg)
    for obs in tail.observations:
        sit = tracker.update(obs)
    if tail.rollout_ref is not None:  # the second pass: the desired poses are replaced
        sit = replace(sit.with_reference(tail.rollout_ref), ref_speed_mps=tail.rollout_speed_mps)
    return sit


@pytest.mark.parametrize("preset_name, layout_name", [("paper", "paper"), ("improved", "paper"), ("improved", "multi"),
                                                      ("improved", "set")])
def test_dataset_and_deployed_paths_give_identical_features(preset_name, layout_name):
    cfg = preset(preset_name)
    lay = layout_for(layout_name, cfg.horizon)
    rng = np.random.default_rng(3)
    n_obstacles = 0
    for _ in range(60):
        sit = sample_situation(rng, cfg, layout_name)  # what nn_export.training.dataset labels
        tail = sit.info["tail"]
        deployed = _replay_deployed(tail, cfg)
        np.testing.assert_array_equal(compute_features(lay, sit), compute_features(lay, deployed))
        n_obstacles += len(sit.tracks)
    assert n_obstacles > 30  # the comparison did cover obstacles


def _transform_tail(tail, angle, shift):
    """The same history in a world rotated by ``angle`` and shifted by ``shift``."""
    c, s = math.cos(angle), math.sin(angle)

    def pt(x, y):
        return (c * x - s * y + shift[0], s * x + c * y + shift[1])

    path = tail.observations[0].reference
    sx, sy = pt(*path.start_xy_m)
    new_path = ReferencePath((sx, sy), path.start_heading_rad + angle, path.segments, path.speed_mps)
    obs_out = []
    for o in tail.observations:
        r = o.robot
        x, y = pt(r.x_m, r.y_m)
        robot = RobotState(x, y, r.heading_rad + angle, r.v_right_mps, r.v_left_mps)
        moving = tuple(ObstacleMeasurement(m.obstacle_id, None if m.position_m is None else pt(*m.position_m),
                                           m.radius_m) for m in o.moving)
        static = tuple(StaticObstacle(pt(*st.position_m), st.radius_m) for st in o.static)
        obs_out.append(Observation(o.t_s, robot, new_path, moving, static))
    roll = None
    if tail.rollout_ref is not None:
        xy = np.array([pt(*p[:2]) for p in tail.rollout_ref])
        roll = np.column_stack([xy, tail.rollout_ref[:, 2] + angle])
    return replace(tail, observations=tuple(obs_out), rollout_ref=roll)


@pytest.mark.parametrize("preset_name, layout_name", [("paper", "paper"), ("improved", "multi")])
def test_rotation_and_translation_of_the_world_leave_features_unchanged(preset_name, layout_name):
    cfg = preset(preset_name)
    lay = layout_for(layout_name, cfg.horizon)
    rng = np.random.default_rng(5)
    for i in range(40):
        tail = episode_tail(rng, cfg, layout_name)
        f = compute_features(lay, situation_from_tail(tail, cfg))
        angle = float(rng.uniform(-math.pi, math.pi))
        shift = rng.uniform(-50.0, 50.0, 2)
        g = compute_features(lay, _replay_deployed(_transform_tail(tail, angle, shift), cfg))
        assert_features_close(lay, f, g, 1e-8)


def test_situation_transform_is_an_isometry_of_the_features():
    cfg = preset("improved")
    lay = layout_for("multi", cfg.horizon)
    rng = np.random.default_rng(8)
    for _ in range(20):
        sit = sample_situation(rng, cfg, "multi")
        f = compute_features(lay, sit)
        assert_features_close(lay, compute_features(lay, sit.transformed(2.1, (4.0, -3.0))), f, 1e-9)
        assert_features_close(lay, compute_features(lay, sit.transformed(-0.7, (1.0, 2.0), mirror=True)),
                              mirror_features(lay, f), 1e-9)


def test_track_estimate_is_the_planners_forecast():
    """The features and the labels read the same EKF: the snapshot's forecast is the
    filter's own prediction, and its state is the filter's state."""
    ekf = ObstacleEKF(0.5)
    for k in range(6):
        ekf.step(np.array([3.0 - 0.2 * k, 1.0 + 0.01 * k]))
    tr = track_estimate(ekf, 4, 0.3, 12)
    means, covs = ekf.predict(12)
    np.testing.assert_array_equal(tr.means_m, means)
    np.testing.assert_array_equal(tr.covs_m2, covs)
    np.testing.assert_array_equal(tr.state, ekf.state_)


def test_onnx_policy_computes_the_same_features_when_a_model_is_shipped():
    """The deployed OnnxPolicy, fed the observation stream, ends with the dataset's features
    in its input buffer (skipped until a model for the preset is shipped)."""
    pytest.importorskip("onnxruntime")
    from nn_export import OnnxPolicy, shipped_model_path
    cfg = preset("paper")
    try:
        path = shipped_model_path("paper")
    except (FileNotFoundError, ValueError):
        pytest.skip("no shipped model for preset paper")
    if not path.is_file():
        pytest.skip("no shipped model for preset paper")
    policy = OnnxPolicy(path, preset="paper", two_pass=False)
    lay = policy.layout
    rng = np.random.default_rng(21)
    for _ in range(20):
        tail = episode_tail(rng, cfg, lay.name)
        if tail.rollout_ref is not None:
            continue
        policy.reset()
        for obs in tail.observations:
            policy.decide(obs)
        expected = compute_features(lay, situation_from_tail(tail, cfg))
        np.testing.assert_array_equal(policy._f64, expected)


@pytest.mark.parametrize("layout_name", ["paper", "multi"])
def test_rollout_features_equal_compute_features_exactly(layout_name):
    """The deployed policy's pass-1 features (shared arc terms of overlapping windows, the
    absent-obstacle slots written once) are compute_features of the obstacle-free situation,
    bit for bit, curvature clipping counted the same."""
    from nn_export.runtime.features import RolloutFeatures
    rng = np.random.default_rng(8)
    T, H = 1.5, 6
    lay = layout_for(layout_name, H)
    path = ReferencePath((0.0, 0.0), 0.3, (Segment.line(2.0), Segment.arc(1.5, 1.2), Segment.arc(0.1, -3.0),
                                            Segment.line(3.0)), 0.1)
    seen_clipping = False
    for s0 in (0.0, 1.3, 3.5, 3.8, path.length_m - 0.5, path.length_m):
        ref = reference_poses(path, s0, T, 2 * H - 1)
        rf = RolloutFeatures(lay, ref, T)
        assert rf.windows == H
        clipped = 0
        for j in range(H):
            x, y, th = rng.normal(0, 2, 2).tolist() + [float(rng.uniform(-4, 4))]
            vr, vl = rng.uniform(-0.8, 0.8, 2).tolist()
            rep_a, rep_b = {}, {}
            a = compute_features(lay, Situation(RobotState(x, y, th, vr, vl), ref[j:j + H + 1], T, 0.4), report=rep_a)
            b = rf.fill(j, x, y, th, vr, vl, np.empty(lay.size), rep_b)
            assert np.array_equal(a, b), (s0, j)
            assert rep_a == rep_b
            clipped += rep_a.get("curvature_clipped", 0)
            b32 = rf.fill(j, x, y, th, vr, vl, np.empty(lay.size, np.float32))
            assert np.array_equal(a.astype(np.float32), b32)
        seen_clipping = seen_clipping or clipped > 0
    assert seen_clipping  # the tight arc's curvature is over the limit
    with pytest.raises(IndexError):
        rf.fill(H, 0.0, 0.0, 0.0, 0.0, 0.0, np.empty(lay.size))


def _tail_as_before(P, H, T, lim):
    """The reference tail of one window as the code computed it before branch nnspeed
    (every curvature checked against the limit, the lengths summed with reduce)."""
    from functools import reduce
    from operator import add
    from casadi_gpc.robot import sinc
    kappas, lengths, clipped = [], [], 0
    for (x0, y0, h0), (x1, y1, h1) in zip(P[:-1], P[1:]):
        if h1 == h0:
            length = (x1 - x0) * math.cos(h0 + 0.0) + (y1 - y0) * math.sin(h0 + 0.0)
            kappa = 0.0 / length if abs(length) > 1e-6 else 0.0
        else:
            dth = math.pi - (math.pi - (h1 - h0)) % (2 * math.pi)
            mid = h0 + 0.5 * dth
            length = ((x1 - x0) * math.cos(mid) + (y1 - y0) * math.sin(mid)) / sinc(math, 0.5 * dth)
            kappa = dth / length if abs(length) > 1e-6 else (math.copysign(math.inf, dth) if abs(dth) > 1e-9 else 0.0)
        if abs(kappa) > lim:
            kappa = math.copysign(lim, kappa)
            clipped += 1
        kappas.append(kappa)
        lengths.append(length)
    return kappas + [reduce(add, lengths, 0.0) / (H * T)], clipped


def test_one_window_tail_is_the_first_of_the_general_windows():
    """The single-window form of the reference tail (the decision's own H + 1 desired poses:
    its total kept in order, no slicing, a straight piece's curvature checked only against a
    negative limit) gives exactly what the general form gives for the first window of a
    longer run of poses, and what the code gave before (signs of zero included): lines along
    any heading (+-0.0 included), arcs both ways, a path end (repeated poses), backwards
    pieces, clipped curvatures, and a negative limit."""
    from nn_export.runtime.features import _window_tails
    rng = np.random.default_rng(7)
    H, T = 6, 0.5
    paths = [ReferencePath((rng.normal(0, 3), rng.normal(0, 3)), float(h), segs, 0.4)
             for h in (0.0, -0.0, math.pi, -2.3, 1e-17)
             for segs in ((Segment.line(4.0),), (Segment.line(0.5), Segment.arc(0.1, 1.5), Segment.line(3.0)),
                          (Segment.arc(1.0, -2.0), Segment.arc(3.0, 1.0)))]
    lays = [layout_for("paper", H), replace(layout_for("paper", H), curvature_limit_1pm=-1.0)]
    checked = 0
    for path in paths:
        for s0 in np.linspace(-0.5, path.length_m + 0.5, 17):
            for step in (0.2, -0.15, 0.0):
                rows = path.poses_along(float(s0), step, H + 3)
                for lay in lays:
                    one = _window_tails(lay, rows[:H + 1], T)
                    general = _window_tails(lay, rows, T)
                    before = _tail_as_before(rows[:H + 1], H, T, lay.curvature_limit_1pm)
                    assert len(one) == 1 and len(general) == 3
                    assert one[0][1] == general[0][1] == before[1]
                    for other in (general[0][0], before[0]):
                        a, b = np.array(one[0][0]), np.array(other)
                        np.testing.assert_array_equal(a, b)
                        np.testing.assert_array_equal(np.signbit(a), np.signbit(b))
                    checked += 1
    assert checked == len(paths) * 17 * 3 * 2
