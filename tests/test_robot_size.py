"""Robots of other sizes: the planner's NLP takes the robot's radius as a parameter, so one
compiled NLP serves every size, and the radius enters only where a clearance is taken
(centre distance minus both radii): a robot of radius r among obstacles of radius R costs
what a robot of radius r0 costs among obstacles of radius R + r - r0, term for term (an
independent form of the same geometry, not the code's own arithmetic)."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from casadi_gpc.config import PRESETS
from casadi_gpc.problem.cost import build_problem
from casadi_gpc.robot import RobotParams
from casadi_gpc.solvers.compiling import _library_key
from casadi_gpc.types import ObstacleForecast, StaticObstacle

SHIPPED = RobotParams()
SMALL = replace(SHIPPED, radius_m=0.22)


def _tick(rng, H: int, delta: float, n_moving: int = 3, n_static: int = 2):
    """A robot at the origin driving along x; movers and statics around its path, their radii
    ``R`` (and ``R + delta`` for the second robot); ``(x0, ref, forecasts, statics, forecasts
    inflated, statics inflated)``."""
    x0 = np.array([0.0, 0.0, rng.uniform(-0.2, 0.2), rng.uniform(0.1, 0.5), rng.uniform(0.1, 0.5)])
    ref = np.column_stack([np.linspace(0.3, 3.0, H), np.zeros(H), np.zeros(H)])
    movers, statics = [], []
    for j in range(n_moving):
        start = np.array([rng.uniform(0.8, 3.0), rng.normal(0.0, 1.0)])
        means = start + np.outer(np.arange(1, H + 1), rng.normal(0.0, 0.1, 2))
        A = rng.normal(0.0, 0.05, (H, 2, 2))
        movers.append((j, rng.uniform(0.25, 0.4), means, A @ A.transpose(0, 2, 1) + 1e-3 * np.eye(2)))
    for _ in range(n_static):
        statics.append(((rng.uniform(0.8, 3.0), rng.normal(0.0, 1.0)), rng.uniform(0.25, 0.5)))
    make = lambda d: ([ObstacleForecast(j, r + d, m, c) for j, r, m, c in movers],
                      [StaticObstacle(xy, r + d) for xy, r in statics])
    return x0, ref, *make(0.0), *make(delta)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_one_nlp_serves_every_robot_size(name):
    """The NLP's expressions, and so its compiled library's name, do not depend on the radius;
    the radius is the parameters' last block, written by the layout of the robot's problem."""
    a, b = build_problem(PRESETS[name], SHIPPED), build_problem(PRESETS[name], SMALL)
    assert _library_key("fatrop", a.nlp, "gcc", {}) == _library_key("fatrop", b.nlp, "gcc", {})
    assert a.layout.size == b.layout.size and a.layout.slices()["robot_r"].stop == a.layout.size
    assert a.code_key == b.code_key  # a second size in one process loads the first's library
    assert build_problem(PRESETS[name], replace(SMALL, wheel_base_m=0.45)).code_key != a.code_key
    x0, ref = np.zeros(5), np.zeros((a.config.horizon, 3))
    assert a.layout.pack(x0, ref)[-1] == 0.35 and b.layout.pack(x0, ref)[-1] == 0.22


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_a_smaller_robot_costs_what_the_shipped_one_costs_among_smaller_obstacles(name):
    """Every term of the cost (the margin's and the beyond-horizon penalty's too) of a robot of
    0.22 m among movers and pillars of radius R equals that of the 0.35 m robot among the same
    of radius R - 0.13, at random plans; and differs from the 0.35 m robot's among radius R
    (the parameter is read)."""
    cfg = PRESETS[name]
    if cfg.clearance_margin_m is not None:
        cfg = cfg.with_overrides(beyond_horizon_s=(1.0, 2.0))
    small, shipped = build_problem(cfg, SMALL), build_problem(cfg, SHIPPED)
    rng, H, delta = np.random.default_rng(5), cfg.horizon, SHIPPED.radius_m - SMALL.radius_m
    dv, moved = small.ubx[0], 0
    for _ in range(30):
        x0, ref, movers, statics, movers_shifted, statics_shifted = _tick(rng, H, -delta, min(3, cfg.max_moving),
                                                                  min(2, cfg.max_static))
        u = rng.uniform(-dv, dv, small.n_u)
        a = np.array([float(t) for t in small.terms_fn(u, small.layout.pack(x0, ref, movers, statics))])
        b = np.array([float(t) for t in shipped.terms_fn(u, shipped.layout.pack(x0, ref, movers_shifted, statics_shifted))])
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)
        c = np.array([float(t) for t in shipped.terms_fn(u, shipped.layout.pack(x0, ref, movers, statics))])
        moved += not np.allclose(a[2:], c[2:], rtol=1e-6)
    assert moved >= 10


def test_a_smaller_robot_keeps_its_own_distance_from_a_wall():
    """A wall parallel to the path 0.13 m further from the 0.35 m robot than from the 0.22 m one
    gives the same cost, term for term (the wall's clearance: its distance minus the radius)."""
    cfg = PRESETS["improved"].for_walls(True)
    assert cfg.max_walls
    small, shipped = build_problem(cfg, SMALL), build_problem(cfg, SHIPPED)
    rng, H, delta = np.random.default_rng(8), cfg.horizon, SHIPPED.radius_m - SMALL.radius_m
    dv = small.ubx[0]
    for _ in range(20):
        x0, ref = np.array([0.0, 0.0, 0.0, 0.3, 0.3]), np.column_stack(
            [np.linspace(0.3, 3.0, H), np.zeros(H), np.zeros(H)])
        y = rng.uniform(0.5, 1.2)
        u = rng.uniform(-dv, dv, small.n_u) * 0.05  # the plan stays below the wall
        a = np.array([float(t) for t in small.terms_fn(u, small.layout.pack(x0, ref, walls=[(-50.0, y, 50.0, y)]))])
        b = np.array([float(t) for t in shipped.terms_fn(
            u, shipped.layout.pack(x0, ref, walls=[(-50.0, y + delta, 50.0, y + delta)]))])
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-9)


# -- the deployed network: a smaller robot than it was trained for -----------------------------

def test_which_robots_a_network_drives():
    """The trained robot, or one smaller and the same otherwise; never a larger one, nor other
    wheels (the outputs are those wheels' speeds)."""
    from nn_export.runtime.model_file import serves_robot
    trained = SHIPPED.to_dict()
    assert serves_robot(trained, SHIPPED) and serves_robot(trained, SMALL)
    assert serves_robot(trained, replace(SHIPPED, radius_m=0.35))
    assert not serves_robot(trained, replace(SHIPPED, radius_m=0.36))
    assert not serves_robot(trained, replace(SMALL, wheel_base_m=0.45))
    assert not serves_robot(trained, replace(SMALL, max_wheel_speed_mps=1.0))
    assert not serves_robot({**trained, "radius_m": None}, SMALL)


def test_the_shipped_network_drives_a_smaller_robot_and_refuses_a_larger_one():
    from nn_export import OnnxPolicy
    small = OnnxPolicy(robot=SMALL)
    assert small.robot == SMALL and small._crowd is not None and small._walls is not None
    with pytest.raises(ValueError, match="another robot .*radius_m.*up to its own radius"):
        OnnxPolicy(robot=replace(SHIPPED, radius_m=0.45))
    with pytest.raises(ValueError, match="another robot .*wheel_base_m") as info:
        OnnxPolicy(robot=replace(SMALL, wheel_base_m=0.45))
    assert "up to its own radius" not in str(info.value)
    # the smaller disc, which it drives, is not named among what refuses it (it was: "radius_m,
    # wheel_base_m differ"); a larger disc beside other wheels is
    assert "radius_m" not in str(info.value)
    with pytest.raises(ValueError, match=r"another robot \(radius_m, wheel_base_m differ"):
        OnnxPolicy(robot=replace(SHIPPED, radius_m=0.45, wheel_base_m=0.45))


def test_a_smaller_robot_behind_the_planner_free_check_crosses_a_crowd_with_its_own_radius():
    """The deployed controller (`nn`, no planner on standby) on a 0.22 m robot among 10 walkers:
    each of three crossings reaches the goal without collision (the simulator's clearances
    taken with the robot's own disc)."""
    from casadi_gpc.config import preset
    from gpcnav.controllers import ControllerSpec, make
    from scenarios.simulator import simulate
    from scenarios.suites import Suite
    cfg = preset("improved")
    suite = Suite("circle-crossing", 3, 1, 10, "orca")
    for i in range(3):
        sc = suite.scenario(i)
        small = replace(sc, robot=SMALL)
        log = simulate(small, make(ControllerSpec("nn"), cfg, small.robot), "nn")
        assert log.outcome == "reached_goal", (i, log.outcome)
        assert log.min_clearance_m > 0.0


def test_make_files_refuses_a_radius_the_loader_refuses_and_writes_nothing(tmp_path):
    """docs/data/robot_size/make_files.py wrote every file of a radius gpcnav then refused (a
    negative one, a corridor robot touching the walls); now one line, exit 2, no file."""
    import subprocess
    import sys

    from conftest import REPO
    from scenarios import load_scenario
    script = REPO / "docs" / "data" / "robot_size" / "make_files.py"

    def make(radius, out):
        return subprocess.run([sys.executable, str(script), "corridor", "2", "901", "-", "-", radius, str(out)],
                              capture_output=True, text=True, timeout=120, cwd=REPO)

    for radius in ("-1", "1.3"):
        proc = make(radius, tmp_path / radius)
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
        assert "corridor-orca-5-901-0000" in proc.stderr and not (tmp_path / radius).exists()
    proc = make("0.25", tmp_path / "ok")
    assert proc.returncode == 0, proc.stderr
    files = sorted((tmp_path / "ok").glob("*.toml"))
    assert len(files) == 2 and all(load_scenario(f).robot.radius_m == 0.25 for f in files)


def test_an_evaluation_records_each_episode_s_robot_radius(tmp_path):
    """An evaluation of files with robots of two sizes said nothing of either (RUN.json did)."""
    import json

    from conftest import straight_line_toml
    from gpcnav.cli import main
    text = straight_line_toml("line", duration_s=15.0)
    (tmp_path / "big.toml").write_text(text, encoding="utf-8")
    (tmp_path / "small.toml").write_text(text.replace("[robot]\n", "[robot]\nradius_m = 0.22\n", 1), encoding="utf-8")
    out = tmp_path / "EVAL.json"
    assert main(["evaluate", str(tmp_path / "big.toml"), str(tmp_path / "small.toml"), "--controller", "blind",
                 "--workers", "1", "--out", str(out)]) == 0
    detail = json.loads(out.read_text())["episodes_detail"]
    assert [d["robot_radius_m"] for d in detail] == [0.35, 0.22]
