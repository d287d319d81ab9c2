"""Near ties between passing left and right (nn_export.training.ties, Labeller(tie_margin=...)):
known answers for the side of a plan, the rule, the mirror sample, and the GPC on an exactly
symmetric head-on situation, where without the convention a sample and its mirror carry
opposite answers for the same inputs."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from scenarios.metrics import passing_sides
from nn_export.training.labels import GUESS_NAMES, Label
from nn_export.training.ties import LEFT, RIGHT, choose, passing_side, prefers_right

H = 6


def _straight_poses(y_offsets):
    return np.column_stack([np.arange(1, H + 1, dtype=float), np.asarray(y_offsets, dtype=float)])


def test_passing_side_head_on_known_answers():
    """An obstacle waiting on the path at x = 4: a plan that swerves to y < 0 passes it on
    the right, one that swerves to y > 0 on the left (the desired heading is +x)."""
    obstacle = np.tile([4.0, 0.0], (H, 1))
    headings = np.zeros(H)
    swerve = [0.0, -0.3, -0.8, -1.0, -0.8, -0.3]
    assert passing_side(_straight_poses(swerve), obstacle, headings) == RIGHT
    assert passing_side(_straight_poses(-np.asarray(swerve)), obstacle, headings) == LEFT


def test_passing_side_crossing_and_frame():
    """Crossing from the right (the obstacle moves +y at x = 3): passing behind it (it is on
    the robot's left at the closest approach) is the right pass; the answer turns with the
    desired heading (the same scene rotated by 90 degrees)."""
    obstacle = np.column_stack([np.full(H, 3.0), -2.0 + 0.5 * np.arange(1, H + 1)])  # y = -1.5 .. 1
    behind = _straight_poses(np.zeros(H)) * [0.45, 1.0]  # slow: x = 0.45 .. 2.7, still on the path
    ahead = _straight_poses(np.zeros(H))                 # x = 1 .. 6, over the crossing first
    assert passing_side(behind, obstacle, np.zeros(H)) == RIGHT
    assert passing_side(ahead, obstacle, np.zeros(H)) == LEFT
    rot = np.array([[0.0, -1.0], [1.0, 0.0]])
    assert passing_side(behind @ rot.T, obstacle @ rot.T, np.full(H, np.pi / 2)) == RIGHT


def test_the_rule():
    assert prefers_right(10.05, 10.0, 0.01) and not prefers_right(10.2, 10.0, 0.01)
    assert prefers_right(10.0, 10.0, 0.0) and not prefers_right(10.0 + 1e-6, 10.0, 0.0)
    r, left = Label(True, np.zeros(2), np.zeros((H, 2)), 10.05, "", "", 1, np.zeros(len(GUESS_NAMES)), 0.0), None
    assert choose(r, left, 0.01) is r and choose(None, r, 0.01) is r


def _label(cost, wheels, side):
    plan = np.tile(np.asarray(wheels, dtype=float), (H, 1))
    return Label(True, plan[0].copy(), plan, cost, "ok", "swerve_right" if side == RIGHT else "swerve_left", 3,
                 np.arange(float(len(GUESS_NAMES))), 0.0, side=side)


@pytest.mark.parametrize("margin, side", [(0.01, RIGHT), (0.001, LEFT)])
def test_mirror_sample_applies_the_rule(margin, side):
    """The pass on the right costs 0.5 % more than the one on the left. Within a 1 % margin
    the label is the right pass, with 0.1 % the cheaper left pass. The mirror situation's
    right pass is this one's left pass, reflected (wheels (0.5, 0.3) -> (0.3, 0.5)), and is
    its cheaper one: its label either way. So inside the margin the situation and its mirror
    both pass on the right (one rule), outside it each takes its cheaper pass."""
    right, left = _label(10.05, (0.3, 0.5), RIGHT), _label(10.0, (0.5, 0.3), LEFT)
    pick = choose(right, left, margin)
    label = replace(pick, alternative=left if pick is right else right, tie_margin=margin)
    assert label.side == side
    m = label.mirrored()
    assert m.side == RIGHT and m.cost == 10.0
    np.testing.assert_array_equal(m.wheels_mps, (0.3, 0.5))
    assert m.mirrored().side == label.side and np.array_equal(m.mirrored().wheels_mps, label.wheels_mps)


def test_plain_mirror_without_margin_swaps_wheels():
    label = _label(10.0, (0.3, 0.5), RIGHT)
    m = label.mirrored()
    assert m.side == LEFT and tuple(m.wheels_mps) == (0.5, 0.3) and m.guess == "swerve_left"


def test_passing_sides_of_runs():
    """scenarios.metrics.passing_sides: a robot driving +x past an obstacle that stands at
    (5, 0) passes it on the right when it goes by at y = -1, on the left at y = +1."""
    x = np.linspace(0.0, 10.0, 21)
    obstacle = np.tile([[5.0, 0.0]], (21, 1, 1))
    assert passing_sides(np.column_stack([x, -np.ones(21)]), obstacle) == (RIGHT,)
    assert passing_sides(np.column_stack([x, np.ones(21)]), obstacle) == (LEFT,)


def _head_on(config, gap_m):
    """An exactly symmetric head-on situation: the robot on a straight path at the reference
    point, an obstacle measured without noise on the path, ``gap_m`` ahead, coming at 0.3 m/s."""
    from casadi_gpc.reference import ReferencePath, Segment
    from casadi_gpc.robot import RobotState
    from casadi_gpc.types import Observation, ObstacleMeasurement
    from nn_export.runtime.tracker import SituationTracker
    path = ReferencePath((0.0, 0.0), 0.0, (Segment(30.0, 0.0),), 0.4)
    tracker, T = SituationTracker(config), config.sample_time_s
    for k in range(4):
        t = k * T
        x_obs = 0.4 * 3 * T + gap_m - 0.3 * (t - 3 * T)
        sit = tracker.update(Observation(t, RobotState(0.4 * t, 0.0, 0.0, 0.4, 0.4), path,
                                         (ObstacleMeasurement(0, (x_obs, 0.0), 0.3),), ()))
    return sit


def test_gpc_exact_tie_is_labelled_as_a_function_of_the_situation():
    """On an exactly symmetric head-on situation the GPC's two passes cost the same. The
    mirror sample of the planner's answer is the other pass for the same inputs (the
    inconsistency); with the convention the situation, its mirror sample and the GPC's
    answer on the mirrored situation are one answer: the pass on the right."""
    from casadi_gpc.config import preset
    from nn_export.runtime.features import compute_features, mirror_features
    from nn_export.runtime.layouts import layout_for
    from nn_export.training.labels import Labeller
    cfg = preset("paper")
    sit = _head_on(cfg, 5.0)
    layout = layout_for("paper", cfg.horizon)
    f = compute_features(layout, sit)
    np.testing.assert_allclose(mirror_features(layout, f), f, atol=1e-9)  # the inputs are their own mirror
    plain = Labeller(cfg).label(sit)
    assert plain.wheels_mps[0] < plain.wheels_mps[1]  # the planner's tie-break: swerve right
    assert plain.mirrored().wheels_mps[0] > plain.mirrored().wheels_mps[1]  # its mirror sample: left, same inputs
    lab = Labeller(cfg, tie_margin=0.01)
    label = lab.label(sit)
    assert label.side == RIGHT and label.alternative is not None and label.alternative.side == LEFT
    assert label.alternative.cost == pytest.approx(label.cost, rel=1e-9)
    np.testing.assert_allclose(label.mirrored().wheels_mps, label.wheels_mps, atol=1e-5)
    np.testing.assert_allclose(lab.label(sit.mirrored()).wheels_mps, label.wheels_mps, atol=1e-5)
    np.testing.assert_allclose(label.wheels_mps, plain.wheels_mps, atol=1e-5)  # the planner's own answer
