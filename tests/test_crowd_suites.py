"""The crowd suites (scenarios.crowd_suite) in CrowdNav's geometry, as the contract gives it."""
from __future__ import annotations

import math

import numpy as np
import pytest

from scenarios import Suite
from scenarios.crowd_suite import ROBOT_GAP_M, START_GAP_M, crowd_scenario
from scenarios.model import MovingObstacleSpec, WalkerSpec


def _starts_goals(sc):
    starts = np.array([m.position_m for m in sc.moving])
    goals = []
    for m in sc.moving:
        if isinstance(m, WalkerSpec):
            goals.append(m.goal_m)
    return starts, np.array(goals)


@pytest.mark.parametrize("movers", [5, 10])
def test_circle_crossing_geometry(movers):
    for i in range(20):
        sc = crowd_scenario("circle-crossing", i, 1, movers, "orca")
        assert len(sc.moving) == movers
        assert (sc.robot_start.x_m, sc.robot_start.y_m) == (0.0, -4.0)
        np.testing.assert_allclose(sc.reference.end_pose[:2], (0.0, 4.0), atol=1e-12)
        assert sc.reference.speed_mps == 0.4 and sc.duration_s == pytest.approx(60.0)
        starts, goals = _starts_goals(sc)
        np.testing.assert_allclose(np.hypot(*starts.T), 4.0)          # on the circle
        np.testing.assert_allclose(goals, -starts)                    # to the opposite point
        for m in sc.moving:
            assert m.radius_m == 0.3 and 0.3 <= m.preferred_speed_mps <= 0.5 and not m.sees_robot
        for pts in (starts, goals):
            d = np.hypot(*(pts[:, None] - pts[None]).transpose(2, 0, 1)) + np.eye(movers) * 99
            assert d.min() >= 0.6 + START_GAP_M - 1e-12
        assert np.min(np.hypot(*(starts - (0.0, -4.0)).T)) >= 0.65 + ROBOT_GAP_M - 1e-12


def test_square_crossing_geometry():
    for i in range(30):
        sc = crowd_scenario("square-crossing", i, 3, 5, "social_force")
        starts, goals = _starts_goals(sc)
        for s, g in zip(starts, goals):
            on_side = np.isclose(np.abs(s), 5.0)
            assert on_side.sum() == 1                                  # on one side of the square...
            axis = int(np.flatnonzero(on_side)[0])
            assert g[axis] == pytest.approx(-s[axis])                  # ... to the opposite side
            assert np.all(np.abs(s) <= 5.0) and np.all(np.abs(g) <= 5.0)
        assert all(m.behaviour == "social_force" for m in sc.moving)


def test_constant_movers_keep_the_course_from_start_to_goal():
    walk = crowd_scenario("circle-crossing", 4, 2, 6, "orca")
    const = crowd_scenario("circle-crossing", 4, 2, 6, "constant")
    for w, c in zip(walk.moving, const.moving):
        assert isinstance(c, MovingObstacleSpec) and c.turn_rate_rad_s == 0.0
        assert c.position_m == w.position_m and c.speed_mps == w.preferred_speed_mps
        t_goal = math.hypot(w.goal_m[0] - w.position_m[0], w.goal_m[1] - w.position_m[1]) / c.speed_mps
        x, y, _ = c.state_at(t_goal)
        assert (float(x), float(y)) == pytest.approx(w.goal_m, abs=1e-9)


def test_a_suite_is_fixed_by_its_seed_and_an_index_does_not_depend_on_the_count():
    a = Suite("circle-crossing", 5, 7, movers=10).scenarios()
    b = Suite("circle-crossing", 12, 7, movers=10).scenarios()
    assert a == b[:5]
    assert a != Suite("circle-crossing", 5, 8, movers=10).scenarios()
    assert len({s.name for s in b}) == 12 and len({s.sensing.seed for s in b}) == 12


def test_bad_suite_arguments_are_refused():
    with pytest.raises(ValueError, match="unknown suite"):
        Suite("circles")
    with pytest.raises(ValueError, match="behaviour"):
        Suite("circle-crossing", behaviour="rvo")
    with pytest.raises(ValueError, match="count"):
        Suite("square-crossing", count=0)
    with pytest.raises(ValueError, match="cannot place"):
        crowd_scenario("circle-crossing", 0, 0, 60, "orca")  # 60 discs do not fit on the circle
