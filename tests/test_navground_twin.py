"""gpcnav.navground_twin: a scenario file run inside navground's simulator (the reverse check
of the peers), checked on scenes whose outcome is known."""
from __future__ import annotations

import numpy as np
import pytest

from conftest import straight_line_toml
from scenarios import load_scenario

navground = pytest.importorskip("navground")
from gpcnav.navground_twin import ROBOT_ID, TIME_STEP_S, TwinSettings, run_twin, twin_world  # noqa: E402

# a walker going the other way on the robot's line: it meets the robot head-on
HEAD_ON = """
[[moving_obstacles]]
position = [4.0, 0.0]
radius_m = 0.3
behaviour = "orca"
goal = [-3.0, 0.0]
preferred_speed_mps = 0.4
sees_robot = {sees}
"""


def _scene(write_scenario, sees: bool, name="head_on"):
    return load_scenario(write_scenario(straight_line_toml(name, duration_s=30.0, line_m=4.0,
                                                           extra=HEAD_ON.format(sees=str(sees).lower()))))


@pytest.mark.parametrize("sees", [False, True])
def test_a_walker_sees_the_robot_only_if_the_scenario_says_so(write_scenario, sees):
    world = twin_world(_scene(write_scenario, sees), TwinSettings())
    for _ in range(10):
        world.update(TIME_STEP_S)
    robot, walker = world.agents
    assert robot.id == ROBOT_ID
    ids = [n.id for n in walker.behavior.environment_state.neighbors]
    assert (ROBOT_ID in ids) == sees
    assert [n.id for n in robot.behavior.environment_state.neighbors] == [0]  # the robot sees the walker


def test_a_blind_walker_runs_into_a_robot_that_does_not_avoid(write_scenario):
    # navground's Dummy drives straight to its goal, avoiding nothing: a blind walker meets it
    # head-on (they close 4 m - 0.65 m of radii at up to 0.8 m/s: after about 4.3 s, and
    # navground's own collision record must catch it, as it pushes the discs apart), a
    # walker that sees it goes round
    blind = run_twin(_scene(write_scenario, False), TwinSettings(behaviour="Dummy"))
    seeing = run_twin(_scene(write_scenario, True, "seeing"), TwinSettings(behaviour="Dummy"))
    assert blind.outcome == "collided"
    assert 4.0 < blind.end_time_s < 5.0
    assert blind.min_clearance_m <= 0.0
    assert seeing.outcome == "reached_goal" and seeing.min_clearance_m > 0.0


def test_orca_robot_reaches_its_goal_by_gpcnav_s_rule(write_scenario):
    out = run_twin(load_scenario(write_scenario(straight_line_toml("free", duration_s=30.0, line_m=4.0))))
    assert out.outcome == "reached_goal"
    assert out.end_time_s >= 10.0 - 1e-6  # not before the reference has reached the end (4 m at 0.4 m/s)
    assert out.path_m == pytest.approx(4.0, abs=0.2)


def test_the_acceleration_limit_bounds_each_wheel(write_scenario):
    """2WDiffDyn with moi = 2: |dv| + |dw| W / 2 <= a dt, i.e. every wheel within a dt."""
    sc = _scene(write_scenario, False)
    world = twin_world(sc, TwinSettings())
    robot = world.agents[0]
    W, a = sc.robot.wheel_base_m, sc.robot.max_wheel_accel_mps2
    last = np.zeros(2)
    for _ in range(100):
        world.update(TIME_STEP_S)
        v = float(np.hypot(*robot.velocity))
        w = float(robot.angular_speed)
        wheels = np.array((v + w * W / 2, v - w * W / 2))
        assert np.all(np.abs(wheels - last) <= a * TIME_STEP_S + 1e-4)
        last = wheels
    assert last.mean() > 0.3  # and it does speed up


def test_the_orca_peer_runs_navground_s_own_time_horizons():
    """gpcnav's `orca` and navground's ORCA as a navground user runs it share their horizons
    (10 s for agents and static obstacles): CrowdNav's 5 s made the peer collide with blind
    walkers several times as often as navground's ORCA (docs/peers.md)."""
    from navground import core

    from gpcnav.peers.navground_peer import OrcaSettings
    orca = core.Behavior.make_type("ORCA")
    settings = OrcaSettings()
    assert settings.time_horizon_s == pytest.approx(orca.get("time_horizon"))
    assert settings.static_time_horizon_s == pytest.approx(orca.get("static_time_horizon"))


def test_navground_s_own_gpc_experiment_is_the_exported_scene():
    """docs/navground/antipodal_gpc_robot.yaml (navground's runner, agent 0 ``type: GPC``) puts
    every agent of run s where tools/export_navground_scenario.py puts it for seed s."""
    import importlib.util

    import yaml
    from navground import core, sim

    from conftest import REPO
    spec = importlib.util.spec_from_file_location("export_navground_scenario",
                                                  REPO / "tools" / "export_navground_scenario.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    core.load_plugins()
    experiment = yaml.safe_load((REPO / "docs" / "navground" / "antipodal_gpc_robot.yaml").read_text())
    assert experiment["run_index"] == 1 and experiment["runs"] == 200
    scenario = sim.load_scenario(yaml.safe_dump(experiment["scenario"]))
    for seed in (1, 2, 200):
        ours = sim.World()
        scenario.init_world(ours, seed=seed)
        exported = tool.antipodal_world(7, 4.0, 0.3, 0.4, 0.1, seed)
        assert [a.behavior.type for a in ours.agents] == ["GPC"] + ["ORCA"] * 6
        for a, b in zip(ours.agents, exported.agents):
            assert np.asarray(a.position) == pytest.approx(np.asarray(b.position), abs=1e-6)
            assert np.asarray(a.task.waypoints[0]) == pytest.approx(np.asarray(b.task.waypoints[0]), abs=1e-6)


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    """A file that is not a scenario, one whose movers navground's world cannot hold, a behaviour
    navground does not know: one line naming it, exit 2, before any run (they were tracebacks)."""
    from conftest import PAPER_DIR
    from gpcnav.navground_twin import main
    (tmp_path / "notes.toml").write_text("not = [toml")
    good = tmp_path / "one.toml"
    good.write_text(straight_line_toml("one"))
    for argv, words in (([str(tmp_path / "notes.toml")], "notes.toml: not valid TOML"),
                        ([str(PAPER_DIR / "fig7_1_head_on.toml")], "mover 0 is not a walker with a goal"),
                        ([str(good), "--behaviour", "Nope"], "--behaviour 'Nope': not a navground behaviour"),
                        # (these were tracebacks, exit 1, or ran: a margin of -1, no worker)
                        ([str(good), "--set", "bogus=1"], "--set bogus: navground's ORCA has no property 'bogus'"),
                        ([str(good), "--set", "time_horizon=x"], "--set time_horizon: a number or true / false"),
                        ([str(good), "--set", "time_horizon"], "--set takes NAME=VALUE"),
                        ([str(good), "--safety-margin", "-1"], "--safety-margin must be a finite number"),
                        ([str(good), "--workers", "0"], "--workers must be at least 1")):
        assert main(argv) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and words in err and "Traceback" not in err


def test_the_twin_table_refuses_a_file_it_cannot_read_in_one_line(tmp_path):
    import subprocess
    import sys

    from conftest import REPO
    (tmp_path / "eval.json").write_text('{"episodes_detail": []}')
    for paths, words in (([tmp_path / "nope.json", tmp_path / "eval.json"], "nope.json: cannot read it"),
                         ([tmp_path / "eval.json", tmp_path / "eval.json"], "not the document expected (no 'episodes')")):
        proc = subprocess.run([sys.executable, str(REPO / "tools" / "twin_table.py"), "scene", *map(str, paths)],
                              capture_output=True, text=True, timeout=60)
        assert proc.returncode == 2 and not proc.stdout
        assert proc.stderr.count("\n") == 1 and words in proc.stderr
