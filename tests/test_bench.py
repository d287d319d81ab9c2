"""The solver benchmark (gpcnav.benchmarks.solvers and ``gpcnav bench``): what is recorded, how the
rows are computed, the choice of the solver, the policy extension point, the command line."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from gpcnav.benchmarks.solvers import (AGREE_FRACTION, REFERENCE, SAME_COST_RELATIVE, choose_solver, policy_rows,
                              record_problems, run_bench, speedups)
from casadi_gpc.config import PRESETS
from casadi_gpc.types import ControlDecision
from scenarios import paper_scenarios

PAPER = PRESETS["paper"]

SHORT = """
name = "bench_short"
duration_s = 12.0
[robot]
position = [0.0, 0.0]
heading_deg = 0.0
[reference]
position = [0.0, 0.0]
heading_deg = 0.0
speed_mps = 0.4
[[reference.segments]]
line_m = 8.0
[[moving_obstacles]]
position = [4.0, -3.0]
heading_deg = 90.0
speed_mps = 0.3
radius_m = 0.3
"""


@pytest.fixture(scope="module")
def short_scenario():
    return replace(paper_scenarios()[1], duration_s=15.0)


@pytest.fixture(scope="module")
def bench_doc(short_scenario):
    return run_bench(short_scenario, PAPER, ["ipopt-warm", "sqpmethod-daqp", "fatrop", "powell"])


def test_recording_has_one_step_problem_per_control_step(short_scenario):
    rec = record_problems(short_scenario, PAPER)
    steps = len(rec.log.compute_time_s)
    assert steps == 10 and len(rec.observations) == steps
    # one warm-started problem per step with a previous plan: all but the first
    assert [q.step for q in rec.primary] == list(range(1, steps))
    assert all(q.start == "warm" and q.lam_x is not None for q in rec.primary)
    assert {q.start for q in rec.multistart if q.step == 0} == {"swerve_right", "swerve_left", "straight",
                                                               "detour_right", "detour_left"}
    # every solve the planner made is there: the controller counted them too
    assert len(rec.problems) == rec.log.events["solves"]
    assert all(q.start != "warm" for q in rec.multistart)
    # the recorded warm start is the previous plan shifted by one step
    d = rec.log.decisions[0]
    np.testing.assert_allclose(rec.primary[0].u0[:-2].reshape(-1, 2),
                               np.diff(np.vstack([[0.0, 0.0], d.planned_wheels_mps]), axis=0)[1:], atol=1e-12)


def test_bench_document_follows_the_contract(bench_doc):
    doc = json.loads(json.dumps(bench_doc, allow_nan=False))
    assert isinstance(doc["problems"], int) and doc["problems"] == 9
    assert isinstance(doc["results"], list) and isinstance(doc["speedup"], dict)
    names = [r["name"] for r in doc["results"]]
    assert names[:4] == ["ipopt-warm", "sqpmethod-daqp", "fatrop", "powell"]
    for r in doc["results"]:
        assert r["kind"] in ("solver", "policy")
        t = r["time_s"]
        assert 0 < t["median"] <= t["p95"] <= t["max"]
        assert len(r["time_samples_s"]) == r["problems"]
        if r["kind"] == "solver":
            assert r["problems"] == doc["problems"]
            assert 0.0 <= r["success_rate"] <= 1.0
            assert r["cost_ratio_to_best"]["median"] >= 1.0 - 1e-12
            assert r["cost_ratio_to_best"]["max"] >= r["cost_ratio_to_best"]["median"]
            assert r["iterations"]["median"] >= 0
            assert r["constraint_violation_mps"]["max"] <= 1e-8
            if r["name"] == "powell":  # slow: the step problems only, and it says so
                assert "multistart" not in r and "total_time_s" not in r
                assert "run on the step problems only" in r["notes"]
                assert r["cost_evaluations"]["median"] > 0
            else:
                assert r["multistart"]["problems"] == doc["multistart_problems"]
                # all recorded solves: the step problems' times plus the multistart ones
                assert r["total_time_s"] > sum(r["time_samples_s"]) + r["multistart"]["time_s"]["max"] * 0.999
    # the reference agrees with itself exactly
    ref = doc["results"][0]
    assert ref["vs_reference"]["as_good_rate"] == 1.0 and ref["vs_reference"]["worse"] == 0
    assert ref["planner_steps"]["as_good_rate"] == 1.0


def test_speedups_are_the_ratios_of_the_medians(bench_doc):
    med = {r["name"]: r["time_s"]["median"] for r in bench_doc["results"]}
    chosen = bench_doc["chosen"]["name"]
    for key, value in bench_doc["speedup"].items():
        a, b = key.split("/")
        assert value == pytest.approx(med[a] / med[b], rel=1e-12)
    assert f"{REFERENCE}/sqpmethod-daqp" in bench_doc["speedup"]
    if chosen != REFERENCE:
        assert bench_doc["chosen"]["speedup_vs_reference"] == pytest.approx(bench_doc["speedup"][f"{REFERENCE}/{chosen}"])


def test_gpc_rows_time_the_full_decision_on_the_recorded_observations(bench_doc):
    rows = {r["name"]: r for r in bench_doc["results"] if r["kind"] == "policy"}
    chosen = bench_doc["chosen"]["name"]
    assert set(rows) == {f"gpc[{REFERENCE}]", f"gpc[{chosen}]"}
    ref = rows[f"gpc[{REFERENCE}]"]
    assert ref["problems"] == bench_doc["problems"] + 1  # every step, the first one too
    # replaying the run's own observations, the reference GPC gives the recorded commands
    assert ref["command_diff_to_recorded_mps"]["max"] == pytest.approx(0.0, abs=1e-9)
    assert ref["fallbacks"] == 0


def _row(name, total, success=1.0, as_good=1.0, steps=1.0, cold_success=1.0, worse=0, better=0):
    return {"name": name, "kind": "solver", "time_s": {"median": 0.0}, "total_time_s": total, "success_rate": success,
            "vs_reference": {"as_good_rate": as_good}, "planner_steps": {"as_good_rate": steps},
            "multistart": {"success_rate": cold_success, "vs_reference": {"worse": worse, "better": better}}}


def test_choose_solver_takes_the_fastest_that_agrees_and_never_fails():
    rows = [_row(REFERENCE, 1.0), _row("a", 0.1, success=0.99), _row("b", 0.2, as_good=AGREE_FRACTION - 0.01),
            _row("c", 0.3, steps=0.5), _row("c2", 0.31, cold_success=0.99), _row("c3", 0.32, worse=3, better=2),
            _row("d", 0.4, worse=2, better=2), _row("e", 0.5)]
    assert choose_solver(rows)[0] == "d"
    assert choose_solver([_row(REFERENCE, 1.0), _row("a", 0.1, success=0.5)])[0] == REFERENCE
    rows.append({"name": "nn", "kind": "policy", "time_s": {"median": 1e-6}})
    assert choose_solver(rows)[0] == "d"  # a policy is not a solver


def test_the_deployed_decision_is_set_against_the_gpc_s_on_the_same_scene():
    """``deployed_against_gpc``: the GPC's decision time over the network's, per scene that has
    both rows (the same run), at the median, p99 and max; scenes with one row are left out."""
    from gpcnav.benchmarks.decisions import deployed_against_gpc
    gpc = [{"scenario": "a", "time_s": {"median": 2e-3, "p99": 40e-3, "max": 60e-3}},
           {"scenario": "b", "time_s": {"median": 1e-3, "p99": 1e-3, "max": 1e-3}}]
    net = [{"scenario": "a", "controller": "nn", "movers": 10, "time_s": {"median": 1e-4, "p99": 8e-4, "max": 2e-3}},
           {"scenario": "c", "controller": "nn", "movers": 1, "time_s": {"median": 1e-4, "p99": 1e-4, "max": 1e-4}}]
    rows = deployed_against_gpc(gpc, net)
    assert [r["scenario"] for r in rows] == ["a"]
    assert rows[0]["speedup_median"] == pytest.approx(20.0) and rows[0]["speedup_p99"] == pytest.approx(50.0)
    assert rows[0]["speedup_max"] == pytest.approx(30.0)


def test_speedups_function():
    rows = [{"name": REFERENCE, "time_s": {"median": 2.0}}, {"name": "x", "time_s": {"median": 0.5}},
            {"name": "y", "time_s": {"median": 1.0}}]
    sp = speedups(rows, "x")
    assert sp == {f"{REFERENCE}/x": 4.0, f"{REFERENCE}/y": 2.0, "y/x": 2.0}


class _Constant:
    """A policy that always answers the same wheel speeds."""

    sample_time_s = PAPER.sample_time_s

    def __init__(self, v):
        self.v, self.resets = v, 0

    def reset(self):
        self.resets += 1

    def decide(self, obs):
        return ControlDecision(self.v, self.v)


def test_policy_rows_extension_point_times_any_policy(short_scenario):
    rec = record_problems(short_scenario, PAPER)
    made = []

    def make():
        made.append(_Constant(0.0))
        return made[-1]

    (row,) = policy_rows(rec, [("still", make)])
    assert made[0].resets == 1
    assert row["kind"] == "policy" and row["problems"] == len(rec.observations)
    recorded = np.array([[d.v_right_mps, d.v_left_mps] for d in rec.log.decisions])
    assert row["command_diff_to_recorded_mps"]["max"] == pytest.approx(np.max(np.abs(recorded)))
    assert row["fallbacks"] == 0


def _gpcnav(*args):
    return subprocess.run([sys.executable, "-m", "gpcnav", "bench", *map(str, args)], capture_output=True, text=True)


def test_cli_refuses_an_unknown_solver_with_one_line():
    proc = _gpcnav("--solvers", "ipopt-warm,snopt")
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "snopt" in lines[0]


def test_cli_refuses_a_bad_scenario_file(write_scenario):
    path = write_scenario(SHORT.replace("duration_s = 12.0", "duration_s = -1.0"))
    proc = _gpcnav(str(path), "--solvers", "ipopt-warm")
    assert proc.returncode == 2 and "duration_s" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1


def test_cli_writes_bench_json_png_and_a_table(write_scenario, tmp_path):
    path = write_scenario(SHORT)
    out, png = tmp_path / "BENCH.json", tmp_path / "bench.png"
    proc = _gpcnav(str(path), "--preset", "paper", "--solvers", "sqpmethod-daqp", "--out", str(out), "--plot", str(png),
                   "--no-gpc-rows", "--no-nn-rows")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_text())
    assert [r["name"] for r in doc["results"]] == ["ipopt-warm", "sqpmethod-daqp"]  # the reference is added
    assert doc["problems"] == 7 and doc["scenario"] == "bench_short"  # 8 steps, the first without a plan
    assert png.stat().st_size > 1000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "sqpmethod-daqp" in proc.stdout and "chosen:" in proc.stdout
    assert all(math.isfinite(r["time_s"]["median"]) for r in doc["results"])
    assert SAME_COST_RELATIVE == 1e-6


def test_a_network_decisions_parts_are_disjoint_stretches_of_its_time():
    """Behind the check, each decision of the shipped networks among 10 walkers says where its
    time went: estimation (with the crowd's forecasts), features and network, check. Those
    are disjoint stretches of the time the simulator takes for the decision: each positive,
    their sum below it. The bench reports their medians; a controller whose decisions do not
    say them gets none."""
    from gpcnav.benchmarks.decisions import decision_parts, policy_decision_run
    from casadi_gpc.config import preset
    from scenarios.simulator import simulate
    from gpcnav.controllers import ControllerSpec, make
    from scenarios import Suite
    sc = Suite("circle-crossing", 1, 1, 10, "orca").scenario(0)
    cfg = preset("improved")
    pol = make(ControllerSpec("nn"), cfg, sc.robot)
    log = simulate(sc, pol, "nn")
    assert pol.policy.counters["crowd_network"] > 0
    for d, t in zip(log.decisions, log.compute_time_s):
        parts = [d.info[k] for k in ("estimation_time_s", "forecast_time_s", "network_time_s", "safety_time_s")]
        assert all(p >= 0.0 for p in parts) and parts[0] > 0 and parts[2] > 0 and parts[3] > 0
        assert sum(parts) < t
    row = policy_decision_run(sc, "nn", make(ControllerSpec("nn"), cfg, sc.robot))
    assert set(row["parts_s"]) == set(row["parts_p99_s"]) == {"estimation", "network", "check", "rest"}
    assert all(v > 0 for v in row["parts_s"].values())
    assert all(row["parts_p99_s"][k] >= row["parts_s"][k] for k in row["parts_s"])
    t = row["time_s"]
    assert t["median"] <= t["p95"] <= t["p99"] <= t["max"]
    assert t["p99"] == np.percentile(row["time_samples_s"], 99)
    # the deployed network is the planner-free check (no standby planner: no CasADi needed)
    assert pol.filter.fallback is None and pol.filter.search_way_out
    assert decision_parts(log.decisions[:3], log.compute_time_s[:3]) is not None
    gpc = simulate(sc, make(ControllerSpec("gpc"), cfg, sc.robot), "gpc")
    assert decision_parts(gpc.decisions, gpc.compute_time_s) is None


def test_the_gpc_decision_rows_run_the_check_that_controller_gpc_runs(monkeypatch):
    """The bench times the GPC behind the check layer as ``--controller gpc`` runs it: the
    settings are the controller registry's (one definition), so a change there is a change
    of what the bench measures. A registry whose GPC check differs (here: the searched way
    out) is what the bench's run is built with."""
    from casadi_gpc.config import preset
    from casadi_gpc.safety import CheckSettings, Shield
    from gpcnav import controllers as C
    from gpcnav.benchmarks.decisions import decision_run
    from scenarios import load_scenario, PAPER_DIR
    seen = []
    init = Shield.__init__

    def spy(self, policy, robot, settings=None, *a, **kw):
        seen.append(settings)
        init(self, policy, robot, settings, *a, **kw)

    monkeypatch.setattr(Shield, "__init__", spy)
    sc = load_scenario(PAPER_DIR / "fig7_1_head_on.toml")
    cfg = preset("improved")
    row = decision_run(sc, cfg)
    assert row["outcome"] == "reached_goal" and row["decisions"] > 0
    assert seen[-1] == C.check_settings("gpc", None, cfg, "on")
    searched = CheckSettings(trust_plans=True, search=True)
    monkeypatch.setitem(C.REGISTRY, "gpc", C.Kind(C.REGISTRY["gpc"].default_shield, lambda *a: searched))
    decision_run(sc, cfg)
    assert seen[-1] == searched


CROWDED_WITH_A_WALL = SHORT + """
[[moving_obstacles]]
position = [9.0, 3.0]
heading_deg = 180.0
speed_mps = 0.4
radius_m = 0.3

[[walls]]
points = [[-1.0, -1.5], [10.0, -1.5]]

[sensing]
range_m = 5.0
"""


def test_a_scene_with_more_movers_than_the_slots_and_walls_is_benched_on_the_nlp_of_each_problem(write_scenario):
    """The planner solves the crowd's NLP (more mover slots) at the ticks that track more
    movers than the preset's slots hold, and an NLP with wall slots where the map has walls;
    the bench records which NLP each problem was posed on and solves it there (it once built
    every solver on the preset's NLP alone, and failed on the first crowd problem with a
    shape error)."""
    from casadi_gpc.problem.cost import build_problem
    from scenarios import load_scenario
    sc = load_scenario(write_scenario(CROWDED_WITH_A_WALL))
    cfg = replace(PAPER, max_moving=1, crowd_moving=2).for_walls(True)
    rec = record_problems(sc, cfg)
    used = rec.nlp_configs()
    # the second mover comes into the sensor's range part way: both NLPs were solved
    assert sorted(c.max_moving for c in used.values()) == [1, 2]
    assert all(c.max_walls == cfg.max_walls > 0 for c in used.values())
    sizes = {k: build_problem(c, sc.robot).layout.size for k, c in used.items()}
    assert len(set(sizes.values())) == 2
    assert all(np.size(q.p) == sizes[q.nlp] for q in rec.problems)
    doc = run_bench(sc, cfg, ["ipopt-warm", "sqpmethod-daqp"], gpc_rows=False)
    slots = {n["moving_slots"]: n["problems"] for n in doc["nlps"]}
    assert set(slots) == {1, 2} and min(slots.values()) > 0
    assert sum(slots.values()) == doc["problems"] + doc["multistart_problems"]
    solvers = [r for r in doc["results"] if r["kind"] == "solver"]
    assert [r["name"] for r in solvers] == ["ipopt-warm", "sqpmethod-daqp"]
    for r in solvers:
        assert r["problems"] == doc["problems"] and r["success_rate"] > 0.9
        assert any(n.startswith("NLP 0: ") for n in r["notes"]) and any(n.startswith("NLP 1: ") for n in r["notes"])
    ipopt = next(r for r in solvers if r["name"] == "ipopt-warm")
    assert ipopt["vs_reference"]["as_good_rate"] == ipopt["success_rate"]  # the reference against itself


def test_the_crowd_decisions_are_pooled_over_episodes_run_one_after_the_other():
    """``crowd_decisions``: the GPC and the deployed network on the same scenes, each scene's
    runs one after the other; the pooled decisions are every run's (the same runs alone give
    the same decisions and outcomes: the closed loops do not depend on the time taken), the
    stats are those of the pooled samples, and the ratios are the GPC's over the network's."""
    from collections import Counter

    from gpcnav.benchmarks.decisions import crowd_decisions
    from gpcnav.commands.bench import pooled_summary
    from gpcnav.controllers import ControllerSpec, make
    from casadi_gpc.config import preset
    from scenarios import Suite
    from scenarios.simulator import simulate
    cfg = preset("improved")
    scenes = [Suite("circle-crossing", 2, 1, 3, "orca").scenario(i) for i in range(2)]
    scenes = [replace(sc, duration_s=8.0) for sc in scenes]
    nn = ControllerSpec("nn")
    doc = crowd_decisions(scenes, cfg, lambda sc: make(nn, cfg, sc.robot))
    assert doc["episodes"] == 2 and doc["scenarios"] == [sc.name for sc in scenes]
    for name, spec in (("gpc", ControllerSpec("gpc")), ("nn", nn)):
        alone = [simulate(sc, make(spec, cfg, sc.robot), name) for sc in scenes]
        row = doc[name]
        assert row["decisions"] == sum(len(log.decisions) for log in alone) == len(row["time_samples_s"]) == 32
        assert row["outcomes"] == dict(Counter(log.outcome for log in alone))
        assert row["interventions"] == sum(int(log.events.get("interventions", 0)) for log in alone)
        t = np.asarray(row["time_samples_s"])
        assert row["time_s"]["median"] == pytest.approx(np.median(t)) and row["time_s"]["max"] == t.max()
        assert row["time_s"]["p99"] == np.percentile(t, 99)
    assert "parts_s" in doc["nn"] and "parts_s" not in doc["gpc"]  # the GPC's decisions do not say their parts
    for k in ("median", "p99", "max"):
        assert doc["gpc_over_nn"][k] == pytest.approx(doc["gpc"]["time_s"][k] / doc["nn"]["time_s"][k])
    lines = pooled_summary({"suite": {"name": "circle-crossing", "movers": 3, "behaviour": "orca", "seed": 1,
                                      "episodes": 2}, **doc})
    assert lines[0].startswith("over the first 2 crossings") and "median" in lines[-1] and "p99" in lines[-1]
    frozen = []  # what the garbage collector left out of its reach while the scenes ran

    def network(sc):
        import gc
        frozen.append(gc.get_freeze_count())
        return make(nn, cfg, sc.robot)
    only_nn = crowd_decisions(scenes[:1], None, network)
    assert "gpc" not in only_nn and "gpc_over_nn" not in only_nn and only_nn["nn"]["decisions"] == 16
    # the objects made before were frozen for the run (a full collection over a bench's heap landed in
    # one decision, 0.1-0.15 s), and are handed back to the collector after it
    import gc
    assert frozen[0] > 1000 and gc.get_freeze_count() == 0


def test_cli_refuses_a_negative_crowd_episodes_in_one_line():
    proc = _gpcnav("--crowd-episodes", "-1", "--solvers", "ipopt-warm")
    assert proc.returncode == 2 and "--crowd-episodes" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1


def test_the_bench_pools_the_crowd_scene_as_its_options_say():
    """``pooled_crowd`` (what ``gpcnav bench`` adds to BENCH.json): the crowd scene's first
    ``--crowd-episodes`` episodes with the controllers the row options leave in; nothing with
    ``--crowd-episodes 0``, ``--crowd-movers 0`` or both row kinds left out."""
    from types import SimpleNamespace

    from casadi_gpc.config import preset
    from gpcnav.commands.bench import pooled_crowd
    cfg = preset("improved")
    args = SimpleNamespace(crowd_movers=2, crowd_episodes=1, no_gpc_rows=True, no_nn_rows=False, model=None)
    doc = {}
    pooled_crowd(args, doc, cfg, lambda msg: None)
    pooled = doc["crowd_decisions"]
    assert pooled["suite"] == {"name": "circle-crossing", "movers": 2, "behaviour": "orca", "seed": 1, "episodes": 1}
    assert pooled["scenarios"] == ["circle-crossing-orca-2-1-0000"] and "gpc" not in pooled
    assert pooled["nn"]["decisions"] == len(pooled["nn"]["time_samples_s"]) > 10
    for changes in ({"crowd_episodes": 0}, {"crowd_movers": 0}, {"no_gpc_rows": True, "no_nn_rows": True}):
        doc = {}
        pooled_crowd(SimpleNamespace(**{**vars(args), **changes}), doc, cfg, lambda msg: None)
        assert doc == {}


def test_the_controller_row_of_nn_runs_the_model_given_with_model(tmp_path):
    """``bench --model MODEL.onnx --controller nn``: the ``nn`` row times MODEL, as ``--controller nn
    --model`` does on every other subcommand; it timed the shipped network under the same label."""
    import argparse

    from synthetic_models import tracker_model

    from casadi_gpc.robot import RobotParams
    from gpcnav.commands.bench import controller_policies
    path = tracker_model(tmp_path / "tracker.onnx", "improved")
    args = argparse.Namespace(controller=["nn", "stand"], shield=False, model=path)
    rows = dict(controller_policies(args, PRESETS["improved"], RobotParams()))
    made = rows["nn"]()
    inner = getattr(made, "policy", made)
    assert Path(inner.model_info["path"]).resolve() == path.resolve()
    assert rows["stand"]() is not None  # the model is the network's alone


def test_the_pooled_crowd_episodes_run_under_a_progress_bar(monkeypatch):
    """CONTRACT.md: a progress bar for any work longer than a few seconds on a terminal. The pooled
    crowd (10 crossings, the GPC and the network on each: 15 s by default) ran under one line."""
    from types import SimpleNamespace

    from casadi_gpc.config import preset
    from gpcnav.commands import bench
    bars = []

    def recorder(iterable=None, **kw):
        bars.append(kw)
        return iterable

    monkeypatch.setattr(bench, "progress", recorder)
    args = SimpleNamespace(crowd_movers=2, crowd_episodes=1, no_gpc_rows=True, no_nn_rows=False, model=None)
    doc = {}
    bench.pooled_crowd(args, doc, preset("improved"), lambda msg: None)
    assert doc["crowd_decisions"]["episodes"] == 1
    assert [b.get("desc") for b in bars] == ["crowd episodes"]


def test_cli_refuses_a_model_that_no_row_would_run(tmp_path):
    """``bench --no-nn-rows --model M.onnx`` (and no ``--controller nn``) ran, the model dropped without a
    word; now one line, exit 2, before any work."""
    proc = _gpcnav("--no-nn-rows", "--model", tmp_path / "m.onnx", "--controller", "orca", "--out", tmp_path / "B.json")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "--model" in proc.stderr and "--no-nn-rows" in proc.stderr
    assert not (tmp_path / "B.json").exists()


def test_cli_refuses_a_shield_with_no_controller_row(tmp_path):
    """``bench --shield`` with no ``--controller`` ran the whole bench, the option doing nothing
    (it puts the --controller rows behind the check layer); now one line, exit 2, before any work."""
    proc = _gpcnav("--shield", "--solvers", "ipopt-warm", "--out", tmp_path / "B.json")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "--shield" in proc.stderr and "--controller" in proc.stderr
    assert not (tmp_path / "B.json").exists()


@pytest.mark.parametrize("options, words", [
    (["--crowd-movers", "0", "--crowd-episodes", "3"], "which --crowd-movers 0 leaves out"),
    (["--no-gpc-rows", "--no-nn-rows", "--crowd-episodes", "3"], "which --no-gpc-rows and --no-nn-rows leave out"),
])
def test_cli_refuses_crowd_episodes_that_nothing_would_pool(tmp_path, options, words):
    """``--crowd-episodes K`` with no crowd scene, or no GPC and no network rows to pool on it,
    ran the bench without them, the option doing nothing; now one line, exit 2, before any work."""
    proc = _gpcnav(*options, "--solvers", "ipopt-warm", "--out", tmp_path / "B.json")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "--crowd-episodes 3" in proc.stderr and words in proc.stderr
    assert not (tmp_path / "B.json").exists()
