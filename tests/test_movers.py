"""Movers that react (scenarios.movers, navground's ORCA and social force): known answers on
constructed encounters, and the scenario format's walkers."""
from __future__ import annotations

import math

import numpy as np
import pytest

from scenarios.movers import CROWD_TIME_STEP_S, GOAL_TOLERANCE_M, MoverWorld
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState
from scenarios.simulator import simulate
from casadi_gpc.types import ControlDecision, StaticObstacle
from scenarios import ScenarioError, scenario_from_dict
from scenarios.model import MovingObstacleSpec, Scenario, Sensing, WalkerSpec

pytest.importorskip("navground")


def _gaps(world: MoverWorld, t_end: float, dt: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    ts = np.arange(0.0, t_end, dt)
    P = world.positions(ts)
    i, j = np.triu_indices(world.n, 1)
    return ts, np.hypot(*(P[:, i] - P[:, j]).transpose(2, 0, 1)) - world.radii[i] - world.radii[j]


@pytest.mark.parametrize("behaviour", ["orca", "social_force"])
def test_two_walkers_head_on_pass_without_overlap_and_reach_their_goals(behaviour):
    a = WalkerSpec((-3.0, 0.0), 0.3, behaviour, (3.0, 0.0), 0.45)
    b = WalkerSpec((3.0, 0.02), 0.3, behaviour, (-3.0, 0.02), 0.4)
    world = MoverWorld([a, b])
    world.advance(40.0)
    _, gaps = _gaps(world, 40.0)
    assert gaps.min() > 0.0  # they never overlap...
    # ... though on a straight line they would have (centres 0.02 m apart sideways)
    end = world.positions(40.0)
    np.testing.assert_allclose(end, [a.goal_m, b.goal_m], atol=GOAL_TOLERANCE_M + 1e-9)
    assert world.counters["arrived"] == 2
    # each swerved: someone left the line y in [0, 0.02] by more than a radius
    ys = world.positions(np.arange(0, 40, 0.1))[:, :, 1]
    assert np.max(np.abs(ys)) > 0.3


def test_a_walker_stands_at_its_goal_and_does_not_overshoot():
    w = WalkerSpec((0.0, 0.0), 0.3, "orca", (1.03, 0.0), 0.5)
    world = MoverWorld([w])
    world.advance(10.0)
    ts = np.arange(0.0, 10.0, CROWD_TIME_STEP_S)
    x = world.positions(ts)[:, 0, 0]
    assert x.max() <= 1.03 + 1e-9
    np.testing.assert_allclose(world.positions(10.0)[0], (1.03, 0.0), atol=GOAL_TOLERANCE_M)
    assert np.all(np.diff(x) >= -1e-12)  # straight there, never back
    # 1.03 m at 0.5 m/s: arrival after about 2.1 s, then standing
    assert np.ptp(world.positions(np.array([3.0, 6.0, 9.9]))[:, 0, 0]) == 0.0


def test_positions_between_grid_instants_are_exactly_linear():
    w = WalkerSpec((0.0, 0.0), 0.3, "orca", (5.0, 2.0), 0.4)
    world = MoverWorld([w])
    world.advance(2.0)
    p0, p1 = world.positions(1.0), world.positions(1.0 + CROWD_TIME_STEP_S)
    np.testing.assert_allclose(world.positions(1.0 + 0.3 * CROWD_TIME_STEP_S), 0.7 * p0 + 0.3 * p1, atol=1e-12)
    with pytest.raises(ValueError, match="known until"):
        world.positions(5.0)


def _robot_standing_at(x, y):
    return lambda t: (x, y, 0.0, 0.0)


def test_walkers_that_do_not_see_the_robot_walk_through_it_and_those_that_do_avoid_it():
    robot_xy = (2.0, 0.0)
    blind = MoverWorld([WalkerSpec((0.0, 0.0), 0.3, "orca", (4.0, 0.0), 0.4, sees_robot=False)], robot_radius_m=0.35)
    blind.advance(12.0, _robot_standing_at(*robot_xy))
    alone = MoverWorld([WalkerSpec((0.0, 0.0), 0.3, "orca", (4.0, 0.0), 0.4)])
    alone.advance(12.0)
    ts = np.arange(0.0, 12.0, 0.05)
    # the blind walker's path is the one it walks with no robot at all: straight through it
    np.testing.assert_array_equal(blind.positions(ts), alone.positions(ts))
    assert np.min(np.hypot(*(blind.positions(ts)[:, 0] - robot_xy).T)) < 0.65
    seeing = MoverWorld([WalkerSpec((0.0, 0.0), 0.3, "orca", (4.0, 0.0), 0.4, sees_robot=True)], robot_radius_m=0.35)
    seeing.advance(12.0, _robot_standing_at(*robot_xy))
    assert np.min(np.hypot(*(seeing.positions(ts)[:, 0] - robot_xy).T)) > 0.65  # around it


def test_constant_movers_follow_their_course_in_the_mixed_world():
    c = MovingObstacleSpec((0.0, 5.0), 0.0, 0.3, 0.3)
    w = WalkerSpec((0.0, -5.0), 0.3, "orca", (0.0, -9.0), 0.4)
    world = MoverWorld([c, w])
    world.advance(10.0)
    ts = np.array([0.0, 3.3, 7.77])
    x, y, _ = c.state_at(ts)
    np.testing.assert_array_equal(world.positions(ts)[:, 0], np.column_stack([x, y]))
    np.testing.assert_allclose(world.velocities(3.3)[0], (0.3, 0.0), atol=1e-12)


def test_walkers_avoid_static_obstacles():
    # (exactly on the line ORCA stops in front of the disc: a symmetric deadlock, as in RVO2)
    world = MoverWorld([WalkerSpec((0.0, 0.0), 0.3, "orca", (6.0, 0.0), 0.4)], [StaticObstacle((3.0, 0.1), 0.4)])
    world.advance(30.0)
    p = world.positions(np.arange(0.0, 30.0, 0.02))[:, 0]
    assert np.min(np.hypot(*(p - (3.0, 0.1)).T)) > 0.7
    np.testing.assert_allclose(p[-1], (6.0, 0.0), atol=GOAL_TOLERANCE_M)


class _Stand:
    sample_time_s = 0.5

    def reset(self):
        pass

    def decide(self, obs):
        return ControlDecision(0.0, 0.0)


def _scenario(walker):
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(2.0),), 0.4)
    return Scenario("walk", 20.0, RobotState(0.0, 0.0, 0.0), ref, RobotParams(), (walker,), (), Sensing(0.0, 0))


def test_the_simulator_collides_a_blind_walker_with_a_standing_robot_and_not_a_seeing_one():
    blind = simulate(_scenario(WalkerSpec((3.0, 0.0), 0.3, "orca", (-3.0, 0.0), 0.4)), _Stand())
    assert blind.outcome == "collided"
    # contact when the centres are 0.65 m apart: the walker has covered 2.35 m at 0.4 m/s
    assert blind.end_time_s == pytest.approx(2.35 / 0.4, abs=0.5)
    # (0.1 m off the line: exactly on it, ORCA stops in front of the robot, a symmetric deadlock)
    seeing = simulate(_scenario(WalkerSpec((3.0, 0.1), 0.3, "orca", (-3.0, 0.1), 0.4, True)), _Stand())
    assert seeing.outcome == "timed_out" and seeing.min_clearance_m > 0.0
    assert seeing.events["movers.arrived"] == 1


BASE = {"name": "w", "duration_s": 10.0, "robot": {"position": [0.0, 0.0], "heading_deg": 0.0},
        "reference": {"position": [0.0, 0.0], "heading_deg": 0.0, "speed_mps": 0.4, "segments": [{"line_m": 4.0}]}}


def _with(mover):
    return dict(BASE, moving_obstacles=[mover])


def test_walker_fields_are_read():
    sc = scenario_from_dict(_with({"position": [3.4, 2.0], "radius_m": 0.3, "behaviour": "social_force",
                                   "goal": [-3.4, -2.0], "preferred_speed_mps": 0.45, "sees_robot": True}))
    assert sc.moving == (WalkerSpec((3.4, 2.0), 0.3, "social_force", (-3.4, -2.0), 0.45, True),)


@pytest.mark.parametrize("mover, field, words", [
    ({"position": [3, 2], "radius_m": 0.3, "behaviour": "orca", "goal": [1, 1], "preferred_speed_mps": 0.0},
     "moving_obstacles[0].preferred_speed_mps", "must be positive"),
    ({"position": [3, 2], "radius_m": 0.3, "behaviour": "rvo2", "goal": [1, 1], "preferred_speed_mps": 0.4},
     "moving_obstacles[0].behaviour", "must be one of"),
    ({"position": [3, 2], "radius_m": 0.3, "behaviour": "orca", "preferred_speed_mps": 0.4},
     "moving_obstacles[0].goal", "missing"),
    ({"position": [3, 2], "radius_m": 0.3, "behaviour": "orca", "goal": [1, 1], "preferred_speed_mps": 0.4,
      "speed_mps": 0.4}, "moving_obstacles[0].speed_mps", "not for a mover"),
    ({"position": [3, 2], "radius_m": 0.3, "heading_deg": 0, "speed_mps": 0.2, "goal": [1, 1]},
     "moving_obstacles[0].goal", "not for a mover"),
    ({"position": [3, 2], "radius_m": 0.3, "behaviour": "orca", "goal": [1, 1], "preferred_speed_mps": 0.4,
      "sees_robot": "yes"}, "moving_obstacles[0].sees_robot", "true or false"),
    ({"position": [3, 2], "radius_m": 0.3, "behaviour": "orca", "goal": [1, math.inf], "preferred_speed_mps": 0.4},
     "moving_obstacles[0].goal", "finite"),
])
def test_bad_walker_fields_are_refused_with_the_field_named(mover, field, words):
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(_with(mover), "w.toml")
    msg = str(err.value)
    assert msg.startswith(f"w.toml: {field}: ") and words in msg and "\n" not in msg
