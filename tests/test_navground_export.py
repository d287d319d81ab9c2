"""tools/export_navground_scenario.py: navground's Antipodal scenario in our scenario format,
checked against navground's own world (places, goals, radii, speeds) and our loader."""
from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest

from conftest import REPO
from scenarios import load_scenario

spec = importlib.util.spec_from_file_location("export_navground_scenario",
                                              REPO / "tools" / "export_navground_scenario.py")
tool = importlib.util.module_from_spec(spec)
spec.loader.exec_module(tool)


def test_the_files_hold_navground_s_world_and_load(tmp_path):
    paths = tool.export(tmp_path, count=3, seed=4, agents=7, radius_m=4.0, position_noise_m=0.1)
    assert [p.name for p in paths] == [f"navground-antipodal-7-{s:05d}.toml" for s in (4, 5, 6)]
    for seed, path in zip((4, 5, 6), paths):
        sc = load_scenario(path)
        robot, *others = tool.antipodal_world(7, 4.0, 0.3, 0.4, 0.1, seed).agents
        # the robot: where agent 0 starts and faces, its reference the line to agent 0's goal
        assert (sc.robot_start.x_m, sc.robot_start.y_m) == pytest.approx(tuple(robot.position), abs=1e-6)
        assert sc.robot_start.heading_rad == pytest.approx(robot.orientation, abs=1e-6)
        assert sc.reference.end_pose[:2] == pytest.approx(np.asarray(robot.task.waypoints[0]), abs=1e-5)
        assert sc.reference.speed_mps == pytest.approx(0.4)
        assert sc.duration_s == pytest.approx(3.0 * sc.reference.duration_s, abs=1e-2)
        assert sc.sensing.seed == seed and sc.robot.radius_m == 0.35  # our robot
        # the walkers: navground's other agents, ORCA, seeing the robot
        assert len(sc.moving) == 6
        for walker, agent in zip(sc.moving, others):
            assert walker.position_m == pytest.approx(tuple(agent.position), abs=1e-6)
            assert walker.goal_m == pytest.approx(tuple(agent.task.waypoints[0]), abs=1e-6)
            assert walker.radius_m == pytest.approx(agent.radius, abs=1e-6) == 0.3
            assert walker.preferred_speed_mps == pytest.approx(agent.behavior.optimal_speed, abs=1e-6)
            assert walker.behaviour == "orca" and walker.sees_robot


def test_without_noise_every_goal_is_the_antipode_at_regular_intervals(tmp_path):
    (path,) = tool.export(tmp_path, count=1, seed=0, agents=8, radius_m=4.0, position_noise_m=0.0,
                          behaviour="social_force", sees_robot=False)
    sc = load_scenario(path)
    starts = [(sc.robot_start.x_m, sc.robot_start.y_m)] + [w.position_m for w in sc.moving]
    goals = [tuple(sc.reference.end_pose[:2])] + [w.goal_m for w in sc.moving]
    for s, g in zip(starts, goals):
        assert math.hypot(*s) == pytest.approx(4.0, abs=1e-5) and g == pytest.approx((-s[0], -s[1]), abs=1e-5)
    angles = sorted(math.atan2(y, x) % (2 * math.pi) for x, y in starts)
    assert np.diff(angles) == pytest.approx(np.full(7, 2 * math.pi / 8), abs=1e-5)
    assert sc.reference.length_m == pytest.approx(8.0, abs=1e-5)
    assert all(w.behaviour == "social_force" and not w.sees_robot for w in sc.moving)


def test_the_corridor_files_hold_navground_s_corridor_unwrapped_and_load(tmp_path):
    """navground's Corridor: its walls (y = 0 and y = width), agent 0 the robot going +x one
    length, every other agent's images in the tiles walking its way, and the file loads."""
    paths, skipped = tool.export_corridor(tmp_path, count=2, seed=3, agents=6, length_m=10.0, width_m=2.5,
                                          sees_robot=False)
    assert skipped == []
    assert [p.name for p in paths] == [f"navground-corridor-6-{s:05d}.toml" for s in (3, 4)]
    for seed, path in zip((3, 4), paths):
        sc = load_scenario(path)
        world = tool.corridor_world(6, 10.0, 2.5, 0.3, 0.35, 0.4, seed)
        robot, *others = world.agents
        assert (sc.robot_start.x_m, sc.robot_start.y_m) == pytest.approx(tuple(robot.position), abs=1e-6)
        assert sc.robot_start.heading_rad == 0.0 and tuple(robot.task.direction) == (1.0, 0.0)
        assert np.asarray(sc.reference.end_pose[:2]) == pytest.approx(np.asarray(robot.position) + (10.0, 0.0), abs=1e-5)
        assert sorted({round(float(w.segments[0][0][1]), 6) for w in sc.walls}) == [0.0, 2.5]
        assert len(sc.walls) == 2 and len(sc.moving) == 5 * len(tool.CORRIDOR_TILES)
        for w in sc.walls:  # every start and goal between the walls' ends
            (x0, _), (x1, _) = w.segments[0]
            assert all(x0 < m.position_m[0] < x1 and x0 < m.goal_m[0] < x1 for m in sc.moving)
        for k, tile in enumerate(tool.CORRIDOR_TILES):
            for walker, agent in zip(sc.moving[5 * k:5 * k + 5], others):
                assert walker.position_m == pytest.approx((agent.position[0] + 10.0 * tile, agent.position[1]),
                                                          abs=1e-5)
                heading = float(agent.task.direction[0])
                assert math.copysign(1.0, walker.goal_m[0] - walker.position_m[0]) == heading
                assert walker.goal_m[1] == walker.position_m[1] and not walker.sees_robot
                # walking at its speed it does not arrive within the time limit
                assert abs(walker.goal_m[0] - walker.position_m[0]) > walker.preferred_speed_mps * sc.duration_s


def test_a_corridor_seed_whose_robot_starts_overlapping_is_named_not_written(tmp_path):
    """navground seed 34 starts agent 0 overlapping another agent's image across the seam."""
    robot, *others = tool.corridor_world(6, 10.0, 2.5, 0.3, 0.35, 0.4, 34).agents
    gap = min(math.hypot(a.position[0] + 10.0 * t - robot.position[0], a.position[1] - robot.position[1])
              - a.radius - robot.radius for a in others for t in (-1, 0, 1))
    assert gap < 0
    paths, skipped = tool.export_corridor(tmp_path, count=2, seed=33)
    assert skipped == [34] and [p.name for p in paths] == ["navground-corridor-6-00033.toml"]


def test_a_corridor_no_wider_than_the_robot_is_refused_before_any_file(tmp_path, capsys):
    """--width 0.5 wrote every file (exit 0) with the 0.7 m robot touching a wall, and gpcnav
    refused each of them; now refused in the tool before anything is written."""
    with pytest.raises(ValueError, match="wider than the robot's disc"):
        tool.export_corridor(tmp_path / "a", count=1, seed=1, width_m=0.5)
    with pytest.raises(SystemExit) as exit_:
        tool.main(["--scene", "corridor", "--out", str(tmp_path / "b"), "--count", "1", "--width", "0.7"])
    assert exit_.value.code == 2 and "wider than the robot's disc" in capsys.readouterr().err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
    paths, _ = tool.export_corridor(tmp_path / "c", count=1, seed=1, width_m=1.0)
    load_scenario(paths[0])  # a corridor wider than the robot loads


def test_an_antipodal_seed_whose_robot_starts_overlapping_is_named_not_written(tmp_path, capsys):
    """20 agents on a 1 m circle: the 0.35 m robot overlaps a walker at the start; the file
    was written and gpcnav refused it. Now left out and named, as the corridor's."""
    skipped = []
    assert tool.export(tmp_path / "a", count=2, seed=1, agents=20, radius_m=1.0, skipped=skipped) == []
    assert skipped == [1, 2]
    assert tool.main(["--out", str(tmp_path / "b"), "--count", "2", "--seed", "1", "--agents", "20",
                      "--radius", "1"]) == 0
    err = capsys.readouterr().err
    assert "2 seeds not written" in err and "0 scenario files" in err
    assert list((tmp_path / "b").glob("*.toml")) == []


def test_an_out_that_is_a_file_is_refused_in_one_line(tmp_path, capsys):
    """--out naming a file was FileExistsError's traceback."""
    (tmp_path / "a").write_text("")
    with pytest.raises(SystemExit) as exit_:
        tool.main(["--out", str(tmp_path / "a"), "--count", "1"])
    assert exit_.value.code == 2 and "--out" in capsys.readouterr().err and (tmp_path / "a").read_text() == ""
