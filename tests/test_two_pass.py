"""The paper's training distribution (nn_export.training.two_pass): the first pass's situations
have no obstacle, the second pass's robot stands at the start of its desired path, which is
the first pass's prediction, and its obstacle is where the deployed policy runs the second
pass; the dataset records which pass each sample is for."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from casadi_gpc.config import preset
from casadi_gpc.robot import RobotState, robot_step
from nn_export.runtime.features import compute_features
from nn_export.runtime.layouts import layout_for
from nn_export.training.dataset import DatasetSpec, read_shard
from nn_export.training.labels import Labeller
from nn_export.training.two_pass import SETTINGS, TwoPassGPC, first_pass_prediction, two_pass_samples

PAPER = preset("paper")


@pytest.fixture(scope="module")
def labeller():
    return Labeller(PAPER)


@pytest.fixture(scope="module")
def draws(labeller):
    rng = np.random.default_rng(11)
    return [two_pass_samples(rng, PAPER, labeller) for _ in range(6)]


def test_first_pass_situations_have_no_obstacle(draws):
    layout = layout_for("paper", PAPER.horizon)
    for (first, label), _ in draws:
        assert first.tracks == () and first.statics == () and first.info["decision_pass"] == 1 and label.converged
        f = compute_features(layout, first)
        np.testing.assert_array_equal(f[2:7], layout.absent_moving)


def test_second_pass_robot_is_on_its_predicted_path(draws, labeller):
    """Step 0 of the desired path is the robot's pose; the path is the first pass rolled out
    (step 1: the robot moved by the first pass's own answer; every step: its labels applied
    with the robot model), at the mean speed of those labels."""
    W, T = labeller.robot.wheel_base_m, PAPER.sample_time_s
    for (first, label), (second, _) in draws:
        r = second.robot
        assert second.info["decision_pass"] == 2 and r == first.robot
        np.testing.assert_allclose(second.ref_poses[0], [r.x_m, r.y_m, r.heading_rad], atol=1e-12)
        x, y, h = robot_step(np, r.x_m, r.y_m, r.heading_rad, *label.wheels_mps, T, W)
        np.testing.assert_allclose(second.ref_poses[1], [x, y, h], atol=1e-12)
        assert len(second.tracks) == 1


def test_rollout_matches_a_step_by_step_replay(labeller):
    """first_pass_prediction("rollout") is the obstacle-free GPC applied step by step, step
    j on the desired poses j..j+H."""
    from nn_export.runtime.tracker import SituationTracker
    from nn_export.training.sampler import sample_situation
    H, T, W = PAPER.horizon, PAPER.sample_time_s, labeller.robot.wheel_base_m
    tracker = SituationTracker(PAPER, reference_steps=2 * H - 1)
    sit = sample_situation(np.random.default_rng(5), PAPER, settings=SETTINGS, tracker=tracker).without_obstacles()
    ahead = tracker.reference_ahead_
    poses, wheels = first_pass_prediction(labeller, sit, ahead)
    state = sit.robot
    from dataclasses import replace
    for j in range(H):
        vr, vl = labeller.label(replace(sit, robot=state, ref_poses=ahead[j:j + H + 1])).wheels_mps
        np.testing.assert_allclose(wheels[j], (vr, vl), atol=1e-9)
        x, y, h = robot_step(np, state.x_m, state.y_m, state.heading_rad, vr, vl, T, W)
        state = RobotState(float(x), float(y), float(h), float(vr), float(vl))
        np.testing.assert_allclose(poses[j + 1], (x, y, h), atol=1e-9)


def test_second_pass_obstacle_comes_near_the_desired_path(draws, labeller):
    """The obstacle's true motion comes within the settings' clearance of the desired path at
    the same step (the deployed policy runs its second pass below 1.0 m)."""
    from casadi_gpc.robot import arc_step
    T = PAPER.sample_time_s
    for _, (second, _) in draws:
        (m,) = second.info["tail"].movers
        x, y, _ = arc_step(np, *m.position_m, m.heading_rad, m.speed_mps, m.turn_rate_rad_s,
                           T * np.arange(1, PAPER.horizon + 1))
        d = np.hypot(x - second.ref_poses[1:, 0], y - second.ref_poses[1:, 1]) - labeller.robot.radius_m - m.radius_m
        assert d.min() <= SETTINGS.second_pass_max_clearance_m + 1e-9


def test_draws_are_reproducible(labeller):
    a = two_pass_samples(np.random.default_rng(3), PAPER, labeller)
    b = two_pass_samples(np.random.default_rng(3), PAPER, labeller)
    for (sa, la), (sb, lb) in zip(a, b):
        np.testing.assert_array_equal(sa.ref_poses, sb.ref_poses)
        np.testing.assert_array_equal(la.wheels_mps, lb.wheels_mps)


def test_oracle_without_obstacle_is_the_gpc_label(labeller):
    """TwoPassGPC on a path without obstacle applies the first pass: the GPC's label."""
    from casadi_gpc.reference import ReferencePath, Segment
    from casadi_gpc.types import Observation
    path = ReferencePath((0.0, 0.0), 0.0, (Segment(20.0, 0.0),), 0.4)
    obs = Observation(0.0, RobotState(0.0, 0.5, 0.1, 0.2, 0.2), path, (), ())
    dec = TwoPassGPC(labeller).decide(obs)
    from nn_export.runtime.tracker import SituationTracker
    expected = labeller.label(SituationTracker(PAPER).update(obs)).wheels_mps
    np.testing.assert_allclose((dec.v_right_mps, dec.v_left_mps), expected, atol=1e-9)
    assert dec.reason.startswith("pass 1")


def test_spec_ids_of_the_sampled_scheme_do_not_change():
    """The new fields enter a dataset's request only when set: datasets made before keep
    their spec_id (resumable), and the two-pass scheme and a tie margin get their own."""
    layout = layout_for("paper", PAPER.horizon)
    base = DatasetSpec(10, PAPER, layout)
    assert "scheme" not in base.request() and "tie_margin" not in base.request()
    two = DatasetSpec(10, PAPER, layout, scheme="two-pass", sampler=SETTINGS)
    tie = DatasetSpec(10, PAPER, layout, tie_margin=0.01)
    assert len({base.spec_id, two.spec_id, tie.spec_id}) == 3
    with pytest.raises(ValueError, match="paper layout"):
        DatasetSpec(10, PAPER, layout_for("multi", PAPER.horizon), scheme="two-pass")


def test_cli_two_pass_dataset_records_the_passes(tmp_path):
    out = tmp_path / "ds"
    proc = subprocess.run([sys.executable, "-m", "gpcnav", "dataset", "--out", str(out), "--samples", "16",
                           "--scheme", "two-pass", "--tie-margin", "0.01", "--preset", "paper", "--workers", "1",
                           "--shard-size", "8"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    a = [read_shard(out / f"shard-0000{i}.npz") for i in range(2)]
    passes = np.concatenate([x["decision_pass"] for x in a])
    mirror = np.concatenate([x["mirror"] for x in a])
    # each draw: first pass, its mirror, second pass, its mirror
    np.testing.assert_array_equal(passes, np.tile([1, 1, 2, 2], 4))
    np.testing.assert_array_equal(mirror, np.tile([False, True], 8))
    f = np.concatenate([x["features"] for x in a])
    assert np.all(f[passes == 1, 2] == -12.0) and np.all(f[passes == 2, 2] > -12.0)


@pytest.mark.parametrize("mode", [pytest.param("plan", marks=pytest.mark.slow), "rollout"])
def test_oracle_second_pass_plans_against_the_prediction(labeller, mode):
    """With an obstacle 3 m ahead on the path, TwoPassGPC runs its second pass: the GPC's
    label of the same situation with the first pass's prediction as the desired poses (an
    independent replay: the prediction rebuilt here from the obstacle-free labels)."""
    from dataclasses import replace

    from casadi_gpc.reference import ReferencePath, Segment
    from casadi_gpc.types import ObstacleMeasurement, Observation
    from nn_export.runtime.tracker import SituationTracker
    from nn_export.training.two_pass import predicted_poses
    path = ReferencePath((0.0, 0.0), 0.0, (Segment(20.0, 0.0),), 0.4)
    obs = Observation(0.0, RobotState(0.0, 0.3, 0.0, 0.4, 0.4), path, (ObstacleMeasurement(0, (3.0, 0.0), 0.3),), ())
    oracle = TwoPassGPC(labeller, mode)
    dec = oracle.decide(obs)
    assert dec.reason == "pass 2: avoiding" and oracle.counters["second_pass"] == 1
    tracker = SituationTracker(PAPER, reference_steps=2 * PAPER.horizon - 1)
    sit = tracker.update(obs)
    free, T, W = sit.without_obstacles(), PAPER.sample_time_s, labeller.robot.wheel_base_m
    if mode == "plan":
        wheels = labeller.label(free).plan_wheels_mps
        poses = predicted_poses(free, wheels, labeller.robot)
    else:
        state, poses, wheels = sit.robot, [sit.robot.as_array()[:3]], []
        for j in range(PAPER.horizon):
            vr, vl = labeller.label(replace(free, robot=state, ref_poses=tracker.reference_ahead_[j:j + 7])).wheels_mps
            x, y, h = (float(a) for a in robot_step(np, state.x_m, state.y_m, state.heading_rad, vr, vl, T, W))
            state = RobotState(x, y, h, float(vr), float(vl))
            poses.append((x, y, h))
            wheels.append((vr, vl))
        poses, wheels = np.array(poses), np.array(wheels)
    np.testing.assert_allclose(poses[0], sit.robot.as_array()[:3])
    expected = labeller.label(replace(sit.with_reference(poses), ref_speed_mps=float(np.mean(wheels)))).wheels_mps
    np.testing.assert_allclose((dec.v_right_mps, dec.v_left_mps), expected, atol=1e-9)
    # the obstacle stands in the way: the answer turns left, away from it (the robot is 0.3 m
    # to its left), where the first pass alone would steer back right onto the path
    first = labeller.label(free).wheels_mps
    assert dec.v_right_mps - dec.v_left_mps > 0.02 and first[0] - first[1] < 0.0


def test_oracle_refuses_an_unknown_first_pass(labeller):
    with pytest.raises(ValueError, match="first_pass"):
        TwoPassGPC(labeller, "guess")
