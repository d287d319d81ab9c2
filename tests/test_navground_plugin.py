"""The navground plugin: navground's state as gpcnav's observation (known answers), the
behaviour's clock (decisions at the controller's sample time, wheels held between, wheel
speeds into navground's twist), the kinematics it refuses, imports that stay light until a
behaviour is made, the entry points, and the example experiment run by navground and read
back from its HDF5 file (the GPC agents reach their targets without a collision)."""
from __future__ import annotations

import math
import os
import shutil
import subprocess
import sys
import warnings
import tomllib
from importlib import metadata

import numpy as np
import pytest

core = pytest.importorskip("navground.core")
sim = pytest.importorskip("navground.sim")

from conftest import REPO  # noqa: E402
from casadi_gpc.types import ControlDecision  # noqa: E402
from gpcnav.navground_plugin import GPCBehavior  # noqa: E402
from gpcnav.navground_state import (  # noqa: E402
    DIRECTION_LINE_M, NeighbourTracks, reference_to_target, static_obstacles, target_key, walls)
from test_deploy_isolation import BLOCKER  # noqa: E402

EXAMPLE = REPO / "docs" / "navground" / "antipodal_gpc.yaml"


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}


# --- navground's state as gpcnav's observation ------------------------------------------
def test_a_point_target_is_the_straight_line_from_the_robot_at_the_optimal_speed():
    ref = reference_to_target(core.Target.Point([4.0, 5.0], 0.3), (1.0, 1.0), 0.4)
    assert ref.start_xy_m == (1.0, 1.0) and ref.start_heading_rad == pytest.approx(math.atan2(4.0, 3.0))
    assert (ref.length_m, ref.speed_mps) == pytest.approx((5.0, 0.4))
    assert ref.end_pose[:2] == pytest.approx((4.0, 5.0))
    assert reference_to_target(core.Target.Point([1.0, 1.0], 0.3), (1.0, 1.0), 0.4) is None   # on it
    assert reference_to_target(core.Target(), (1.0, 1.0), 0.4) is None                          # no point


def test_a_path_target_is_followed_along_the_path_from_the_robot_s_projection():
    """A quarter circle of radius 2 m (navground's ``Path``): the reference turns as the
    path does, from the projection of the robot (at arc length 1 m) to the path's end."""
    def curve(s):
        return (np.array([2.0 * math.cos(s / 2.0), 2.0 * math.sin(s / 2.0)], dtype=np.float32),
                s / 2.0 + math.pi / 2.0, 0.5)
    path = core.Path(lambda p, s0, s1: 1.0, curve, math.pi)
    ref = reference_to_target(core.Target.Point([0.0, 2.0], 0.2, path), (1.8, 1.0), 0.3)
    assert ref.length_m == pytest.approx(math.pi - 1.0)
    assert ref.start_xy_m == pytest.approx((2.0 * math.cos(0.5), 2.0 * math.sin(0.5)), abs=1e-6)
    assert ref.end_pose == pytest.approx((0.0, 2.0, math.pi), abs=1e-4)
    assert {round(s.curvature_1pm, 4) for s in ref.segments} == {0.5}


def test_discs_pass_and_line_segments_are_walls():
    disc, line = core.Disc([3.0, 3.0], 0.4), core.LineSegment([0.0, 0.0], [2.0, 0.0])
    assert [(o.position_m, o.radius_m) for o in static_obstacles([disc])] == [((3.0, 3.0), pytest.approx(0.4))]
    assert walls([line]) == (((0.0, 0.0), (2.0, 0.0)),)
    assert walls([core.LineSegment([1.0, 1.0], [1.0, 1.0])]) == ()     # no length: no wall


def test_neighbours_keep_their_ids_whatever_their_order_and_a_newcomer_gets_a_new_one():
    tracks = NeighbourTracks()

    def n(x, y, vx=0.0):
        return core.Neighbor([x, y], 0.3, [vx, 0.0], 0)   # navground's id: 0 for every agent

    first = tracks.update([n(0.0, 0.0, 1.0), n(3.0, 0.0)], 0.1)
    assert [m.obstacle_id for m in first] == [0, 1]
    again = tracks.update([n(3.0, 0.0), n(0.125, 0.0, 1.0), n(0.0, 5.0)], 0.1)   # order swapped, one more
    assert [(m.obstacle_id, m.position_m) for m in again] == [(1, (3.0, 0.0)), (0, (0.125, 0.0)), (2, (0.0, 5.0))]
    jumped = tracks.update([n(3.0, 1.0)], 0.1)   # 1 m from where id 1 was: not the same obstacle
    assert [m.obstacle_id for m in jumped] == [3]


# --- the behaviour's clock, with a controller that records what it is told -----------
class _Recorder:
    sample_time_s = 0.5

    def __init__(self):
        self.observations, self.resets = [], 0

    def reset(self):
        self.resets += 1

    def decide(self, observation):
        self.observations.append(observation)
        return ControlDecision(0.3, 0.2)


class _RecordingGPC(GPCBehavior, name="GPCRecordingForTests"):
    def make_controller(self):
        self._robot = self.robot_params()
        self._controller = _Recorder()
        self._reset_target()
        return self._controller


WORLD = """
groups:
  - number: 1
    position: [0.0, 0.0]
    orientation: 0.0
    radius: 0.35
    kinematics: {type: 2WDiff, wheel_axis: 0.5, max_speed: 0.8, max_backward_speed: 0.8}
    behavior: {type: GPCRecordingForTests, optimal_speed: 0.4}
    task: {type: Waypoints, waypoints: [[4.0, 0.0]], tolerance: 0.3, loop: false}
    state_estimation: {type: Bounded, range: 10.0}
  - number: 1
    position: [2.0, 1.0]
    radius: 0.3
    kinematics: {type: 2WDiff, wheel_axis: 0.5, max_speed: 0.8}
    behavior: {type: Dummy, optimal_speed: 0.0}
"""


def test_decisions_at_the_controller_s_sample_time_and_the_wheels_held_between():
    world = sim.World()
    sim.load_scenario(WORLD).init_world(world, seed=0)
    agent = world.agents[0]
    speeds = []
    for _ in range(12):                       # navground at 0.1 s: t = 0 .. 1.1 s
        world.update(0.1)
        speeds.append((agent.twist.velocity.copy(), agent.twist.angular_speed))
    recorder = agent.behavior.controller
    obs = recorder.observations
    assert [o.t_s for o in obs] == pytest.approx([0.0, 0.5, 1.0], abs=1e-6) and recorder.resets == 1
    assert (obs[0].robot.v_right_mps, obs[0].robot.v_left_mps) == (0.0, 0.0)
    assert (obs[1].robot.v_right_mps, obs[1].robot.v_left_mps) == pytest.approx((0.3, 0.2), abs=1e-6)
    # wheels (0.3, 0.2) on a 0.5 m axis: 0.25 m/s forward, (0.3 - 0.2) / 0.5 = 0.2 rad/s, every step
    for velocity, omega in speeds:
        assert (float(np.hypot(*velocity)), omega) == pytest.approx((0.25, 0.2), abs=1e-6)
    ref = obs[0].reference
    assert (*ref.start_xy_m, ref.start_heading_rad, ref.length_m, ref.speed_mps) == \
        pytest.approx((0.0, 0.0, 0.0, 4.0, 0.4), abs=1e-6)
    assert all(o.reference is ref for o in obs)
    assert [[(m.obstacle_id, m.position_m, round(m.radius_m, 6)) for m in o.moving] for o in obs] == \
        [[(0, (2.0, 1.0), 0.3)]] * 3 and not obs[0].static
    assert obs[2].robot.x_m > 0.2                # it drove (0.25 m/s for 1 s, on an arc)


def test_a_navground_step_that_does_not_divide_the_sample_time_makes_late_decisions_counted_and_said_once():
    """At 0.3 s steps against the 0.5 s sample time the decisions come at 0, 0.6, 1.2 and 1.5 s:
    two late ones, which were made in silence; now counted, the first said as a warning. At 0.1 s
    steps (the test above) none."""
    world = sim.World()
    sim.load_scenario(WORLD).init_world(world, seed=0)
    agent = world.agents[0]
    with pytest.warns(RuntimeWarning, match=r"time step 0.3 s does not divide the controller's sample time 0.5 s") \
            as said:
        for _ in range(6):  # t = 0 .. 1.5 s
            world.update(0.3)
    assert [o.t_s for o in agent.behavior.controller.observations] == pytest.approx([0.0, 0.6, 1.2, 1.5], abs=1e-6)
    assert agent.behavior.late_decisions == 2 and len(said) == 1
    on_time = sim.World()
    sim.load_scenario(WORLD).init_world(on_time, seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for _ in range(12):
            on_time.update(0.1)
    assert on_time.agents[0].behavior.late_decisions == 0


class _StraightRecorder(_Recorder):
    def decide(self, observation):
        self.observations.append(observation)
        return ControlDecision(0.8, 0.8)


class _StraightRecordingGPC(_RecordingGPC, name="GPCStraightRecordingForTests"):
    def make_controller(self):
        super().make_controller()
        self._controller = _StraightRecorder()
        return self._controller


CORRIDOR = """
groups:
  - number: 1
    position: [2.0, 0.5]
    orientation: 0.0
    radius: 0.35
    kinematics: {type: 2WDiff, wheel_axis: 0.5, max_speed: 0.8, max_backward_speed: 0.8}
    behavior: {type: GPCStraightRecordingForTests, optimal_speed: 0.4}
    task: {type: Direction, direction: [1.0, 0.0]}
"""


def test_a_direction_target_is_a_long_line_that_way_from_the_robot():
    """navground's Direction task (its Corridor scenario's) gives a target with a direction and
    no point: the robot braked for ever in its place (the Corridor's GPC agents stood still)."""
    ref = reference_to_target(core.Target.Direction([0.0, 2.0]), (1.0, 1.0), 0.4)
    assert ref.start_xy_m == (1.0, 1.0) and ref.start_heading_rad == pytest.approx(math.pi / 2)
    assert (ref.length_m, ref.speed_mps) == pytest.approx((DIRECTION_LINE_M, 0.4))
    assert target_key(core.Target.Direction([0.0, 2.0])) == ("direction", 0.0, 1.0)
    assert reference_to_target(core.Target.Direction([0.0, 0.0]), (1.0, 1.0), 0.4) is None


def test_a_robot_the_periodic_world_moves_restarts_where_it_is():
    """In navground's periodic corridor (a lattice 3 m long) the robot driven along it wraps from x
    near 3 to near 0: the controller restarts on a line from there (its clock at 0 again)."""
    world = sim.World()
    sim.load_scenario(CORRIDOR).init_world(world, seed=0)
    world.set_lattice(0, (0.0, 3.0))
    agent = world.agents[0]
    xs = []
    for _ in range(30):
        world.update(0.1)
        xs.append(float(agent.position[0]))
    assert min(xs) < 1.0 and max(xs) > 2.5               # it drove and wrapped
    recorder = agent.behavior.controller
    obs = recorder.observations
    starts = [o.reference.start_xy_m[0] for o in obs]
    assert recorder.resets == 2 and starts[0] == pytest.approx(2.0) and starts[-1] < 1.0
    restart = starts.index(starts[-1])
    assert obs[restart].t_s == 0.0 and obs[restart - 1].t_s > 0.0
    assert all(o.reference.start_heading_rad == pytest.approx(0.0) for o in obs)


def test_kinematics_the_robot_cannot_be_driven_with_are_refused():
    b = core.Behavior.make_type("GPC")
    b.radius = 0.35
    k = core.Kinematics.make_type("2WDiff")
    k.wheel_axis, k.max_speed = 0.5, 0.8
    b.kinematics = k
    with pytest.raises(ValueError, match="max_backward_speed"):   # navground's default: 0 m/s
        b.prepare()
    b.kinematics = core.Kinematics.make_type("Omni")
    with pytest.raises(ValueError, match="2WDiff"):
        b.prepare()
    k.set("max_backward_speed", 0.8)
    b.kinematics = k
    robot = b.robot_params()
    assert (robot.wheel_base_m, robot.radius_m, robot.max_wheel_speed_mps, robot.max_wheel_accel_mps2) == \
        (0.5, 0.35, 0.8, 0.8)


def test_a_network_agent_larger_than_the_model_s_robot_is_refused_as_the_behaviour_s_error(tmp_path):
    """It came out of navground's run as gpcnav's UsageError; a smaller agent is driven (its
    model serves robots up to its own radius)."""
    k = core.Kinematics.make_type("2WDiff")
    k.wheel_axis, k.max_speed = 0.5, 0.8
    k.set("max_backward_speed", 0.8)
    b = core.Behavior.make_type("GPCNetwork")
    b.kinematics, b.radius = k, 0.45
    with pytest.raises(ValueError, match=r"^navground behaviour GPCNetwork: .*improved.onnx: model trained for another "
                                         r"robot \(radius_m differ"):
        b.prepare()
    b.radius = 0.3
    b.prepare()
    assert b.robot_params().radius_m == pytest.approx(0.3)


# --- imports, entry points --------------------------------------------------------------
def test_importing_the_plugin_and_making_its_types_loads_no_solver_and_no_network():
    code = BLOCKER.replace('"scipy")', '"scipy", "onnxruntime")') + (
        "from navground import core\nimport gpcnav.navground_plugin\n"
        "b = core.Behavior.make_type('GPCNetwork')\nb.set('preset', 'paper')\nb.set('model', 'x.onnx')\n"
        "g = core.Behavior.make_type('GPC')\ng.set('max_wheel_acceleration', 0.5)\n"
        "print(b.get('preset'), b.get('model'), round(g.get('max_wheel_acceleration'), 3))\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=REPO, env=_env())
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.split() == ["paper", "x.onnx", "0.5"]


def test_the_network_drives_without_casadi():
    code = BLOCKER + (
        "from navground import sim\nimport gpcnav.navground_plugin\n"
        f"w = sim.World()\nsim.load_scenario({WORLD!r}.replace('GPCRecordingForTests', 'GPCNetwork'))"
        ".init_world(w, seed=0)\n"
        "for _ in range(30):\n    w.update(0.1)\n"
        "b = w.agents[0].behavior\n"
        "print(type(b.controller).__name__, b.controller.settings.fallback, w.agents[0].position[0] > 0.3)\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=REPO, env=_env())
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.split() == ["Shield", "manoeuvres", "True"]


def test_the_entry_points_name_the_classes_registered_under_those_names():
    import importlib
    eps = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["entry-points"]["navground_behaviors"]
    assert set(eps) == {"GPC", "GPCNetwork"}
    for name, target in eps.items():
        module, _, cls = target.partition(":")
        assert getattr(importlib.import_module(module), cls)._type == name
    for name in eps:
        assert core.Behavior.make_type(name) is not None
        assert {"preset", "max_wheel_acceleration"} <= set(core.Behavior.type_properties[name])
    assert {"model", "walls_model", "crowd_model"} <= set(core.Behavior.type_properties["GPCNetwork"])


def test_the_network_behaviour_runs_the_walls_network_it_is_given(tmp_path):
    """``walls_model`` (``--walls-model``): the file given answers near walls; one that is not a walls
    network is the behaviour's error."""
    import hashlib

    from synthetic_models import tracker_model
    k = core.Kinematics.make_type("2WDiff")
    k.wheel_axis, k.max_speed = 0.5, 0.8
    k.set("max_backward_speed", 0.8)
    walls = tracker_model(tmp_path / "walls.onnx", "improved", layout_name="set-walls", decision_passes="1")
    b = core.Behavior.make_type("GPCNetwork")
    b.kinematics, b.radius = k, 0.35
    b.set("walls_model", str(walls))
    b.prepare()
    assert b.controller.policy.model_info["walls_model"]["sha256"] == hashlib.sha256(walls.read_bytes()).hexdigest()
    b.set("walls_model", str(tracker_model(tmp_path / "set.onnx", "improved", layout_name="set",
                                           decision_passes="1")))
    with pytest.raises(ValueError, match=r"^navground behaviour GPCNetwork: .*set.onnx: a walls network must read"):
        b.prepare()


# --- the example experiment, recorded by navground and read back ----------------------------
def _check_recorded(path, runs: int):
    from gpcnav.navground_runs import agent_runs, summarise
    gpc = [a for a in agent_runs(path) if a.behaviour == "GPC"]
    assert len(gpc) == 2 * runs and {a.agent for a in gpc} == {0, 1}
    assert all(a.reached and not a.collided and not a.stuck for a in gpc), gpc
    # 8 m at 0.4 m/s is 20 s; the crowd costs them a few seconds, a robot held still far more
    assert all(a.time_to_target_s < 35.0 and a.efficacy > 0.6 for a in gpc), gpc
    by_type = {s.behaviour: s for s in summarise(path)}
    assert set(by_type) == {"GPC", "ORCA"} and by_type["ORCA"].agent_runs == 6 * runs
    assert by_type["ORCA"].collided == 0


def test_the_example_experiment_in_navground_s_api_reaches_without_collision(tmp_path):
    pytest.importorskip("h5py")
    experiment = sim.load_experiment(EXAMPLE.read_text())
    experiment.save_directory = str(tmp_path)
    experiment.run(number_of_runs=2)          # runs 0 and 1 (their seeds)
    _check_recorded(experiment.path, 2)


def test_navground_py_run_knows_the_behaviours_through_the_entry_points(tmp_path):
    """What a navground user types; needs the installed metadata to declare the entry points."""
    pytest.importorskip("h5py")
    declared = {ep.name: ep.value for ep in metadata.entry_points(group="navground_behaviors")}
    if declared.get("GPC") != "gpcnav.navground_plugin:GPCBehavior":
        pytest.skip("the installed gpcnav does not declare the navground entry points: pip install -e .")
    exe = shutil.which("navground_py") or pytest.skip("navground_py is not on PATH")
    r = subprocess.run([exe, "run", str(EXAMPLE), "--runs", "1", "--run_index", "3", "--save_directory",
                        str(tmp_path)], capture_output=True, text=True, timeout=300, cwd=tmp_path, env=_env())
    assert r.returncode == 0, (r.stdout + r.stderr)[-3000:]
    [path] = list(tmp_path.glob("*/data.h5"))
    _check_recorded(path, 1)


def test_the_runs_summary_refuses_what_is_not_navground_s_record_in_one_line(tmp_path, capsys):
    """It ended in h5py's traceback on a missing file or one that is not HDF5."""
    pytest.importorskip("h5py")
    from gpcnav.navground_runs import main
    (tmp_path / "afile").write_text("not HDF5")
    for path in (tmp_path / "missing.h5", tmp_path / "afile"):
        assert main([str(path)]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and str(path) in err and "cannot read navground's recorded runs" in err


def test_an_unknown_preset_is_refused_when_set():
    """It was taken, and the behaviour failed at its first decision, inside a run."""
    b = core.Behavior.make_type("GPC")
    with pytest.raises(ValueError, match="unknown preset 'nonsense'"):
        b.preset = "nonsense"
    b.preset = "paper"
    assert b.preset == "paper"


@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), float("inf")])
def test_a_wheel_acceleration_that_is_not_a_positive_number_is_refused_when_set(value):
    """Zero divided by zero in the check at the first decision, a negative one drove the agent
    away; both were taken (navground's schema marks it positive but does not refuse on set)."""
    for name in ("GPC", "GPCNetwork"):
        b = core.Behavior.make_type(name)
        with pytest.raises(ValueError, match="max_wheel_acceleration must be a positive number"):
            b.max_wheel_acceleration = value
        b.max_wheel_acceleration = 1.5  # (navground keeps it as a float32)
        assert b.max_wheel_acceleration == 1.5


@pytest.mark.parametrize("behaviour", ["GPC", "GPCNetwork"])
def test_navground_s_validate_refuses_what_the_behaviour_refuses(behaviour):
    """``navground_py validate`` (navground's schema) took ``max_wheel_acceleration: 0`` (its schema
    said minimum 0) and ``preset: bogus`` (any text), which the behaviour refuses when set."""
    jsonschema = pytest.importorskip("jsonschema")
    schema = {**core.schema.bundle(), "$ref": "behavior"}
    jsonschema.validate({"type": behaviour, "preset": "paper", "max_wheel_acceleration": 0.5}, schema)
    for bad in ({"preset": "bogus"}, {"max_wheel_acceleration": 0}, {"max_wheel_acceleration": -1}):
        with pytest.raises(jsonschema.ValidationError):
            jsonschema.validate({"type": behaviour, **bad}, schema)


def test_recorded_runs_without_a_record_they_need_say_which(tmp_path, capsys):
    """A data file of an experiment that did not record the world (or the deadlocks): the line
    says which record to switch on (it said only "can't locate attribute: 'world'")."""
    h5py = pytest.importorskip("h5py")
    from gpcnav.navground_runs import main
    path = tmp_path / "data.h5"
    with h5py.File(path, "w") as f:
        run = f.create_group("run_0")
        run.attrs["time_step"] = 0.1
        for name in ("poses", "efficacy", "deadlocks", "collisions"):
            run.create_dataset(name, data=[[0.0]])
    assert main([str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "record_world: true" in err


def test_the_runs_summary_takes_a_waypoint_s_own_tolerance(tmp_path):
    """navground's Waypoints task takes ``tolerances[i]`` for waypoint i where the list reaches it,
    else ``tolerance`` (recorded as 1 m by default): the summary read ``tolerance`` alone, so an agent
    that came within 0.8 m of a waypoint whose own tolerance is 0.3 m was counted reached."""
    h5py = pytest.importorskip("h5py")
    import yaml
    from gpcnav.navground_runs import agent_runs
    tasks = [{"type": "Waypoints", "waypoints": [[4.0, 0.0]], "tolerance": 1.0, "tolerances": [0.3]},
             {"type": "Waypoints", "waypoints": [[2.0, 0.0], [4.0, 0.0]], "tolerance": 1.0, "tolerances": [0.3]}]
    world = {"agents": [{"behavior": {"type": "GPC"}, "task": t} for t in tasks]}
    xs = np.array([0.0, 1.0, 2.0, 3.0, 3.2, 3.2])          # 0.8 m short of (4, 0) at the end
    poses = np.zeros((len(xs), 2, 3))
    poses[:, :, 0] = xs[:, None]
    with h5py.File(tmp_path / "data.h5", "w") as f:
        run = f.create_group("run_0")
        run.attrs["time_step"], run.attrs["world"] = 1.0, yaml.safe_dump(world)
        run.create_dataset("poses", data=poses)
        run.create_dataset("efficacy", data=np.ones((len(xs), 2)))
        run.create_dataset("deadlocks", data=[-1.0, -1.0])
        run.create_dataset("collisions", data=np.zeros((0, 3), dtype=int))
    own, beyond = agent_runs(tmp_path / "data.h5")
    assert own.reached is False                   # its own 0.3 m
    assert beyond.reached and beyond.time_to_target_s == 3.0   # the list does not reach it: 1 m


def test_the_runs_summary_reads_several_experiments_one_table_each(tmp_path, capsys):
    """`python -m gpcnav.navground_runs experiment_*/data.h5` (docs/navground.md) after a second
    experiment in the same folder matched two files, and was refused as unrecognized arguments;
    now one table each under its file's name, and a bad one of them is still one line, exit 2."""
    pytest.importorskip("h5py")
    from gpcnav.navground_runs import main
    text = EXAMPLE.read_text().replace("type: GPC,", "type: GPCNetwork,")
    paths = []
    for k in range(2):
        experiment = sim.load_experiment(text)
        (tmp_path / f"e{k}").mkdir()
        experiment.save_directory = str(tmp_path / f"e{k}")
        experiment.run(number_of_runs=1)
        paths.append(str(experiment.path))
    assert main(paths) == 0
    out = capsys.readouterr().out
    assert out.count("| GPCNetwork | 2 |") == 2 and all(f"{p}:" in out for p in paths)
    assert main([*paths, str(tmp_path / "missing.h5")]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.strip().count("\n") == 0 and "missing.h5" in captured.err
