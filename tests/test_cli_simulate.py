"""``gpcnav simulate`` end to end, and issue 2's must-show on the paper's three scenarios."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from casadi_gpc.config import PRESETS
from casadi_gpc.planner.gpc import GPCController
from scenarios.metrics import run_document
from scenarios.simulator import simulate
from conftest import PAPER_DIR, REPO, check_run_document, straight_line_toml
from scenarios import paper_scenarios


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "gpcnav", *map(str, args)], capture_output=True, text=True,
                          cwd=REPO, timeout=300)


def test_smoke_simulate_writes_run_json_and_plot(tmp_path):
    out, fig = tmp_path / "run.json", tmp_path / "sub" / "fig.png"
    res = run_cli("simulate", PAPER_DIR / "fig7_1_head_on.toml", "--controller", "gpc", "--preset", "paper",
                  "--out", out, "--plot", fig)
    assert res.returncode == 0, res.stderr
    assert "fig7_1_head_on" in res.stdout and "reached_goal" in res.stdout
    doc = json.loads(out.read_text())
    check_run_document(doc)
    assert doc["scenario"] == "fig7_1_head_on" and doc["controller"] == "gpc"
    assert doc["sample_time_s"] == PRESETS["paper"].sample_time_s
    assert fig.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    import matplotlib.image as mpimg
    img = mpimg.imread(fig)
    assert img.shape[0] > 200 and img.shape[1] > 200 and img.std() > 0  # a picture, not a blank page
    assert not list(tmp_path.glob(".*"))  # no temporary files left behind


def test_simulate_and_animate_show_progress_bars_on_a_terminal(tmp_path):
    """CONTRACT.md: a progress bar for any work longer than a few seconds on a terminal. The
    episode and the GIF had none (a 250 s episode among 20 walkers: 35 s drawing its GIF in
    silence); each bar ends full, an episode that reached its goal early too."""
    import re
    from conftest import gpcnav_on_a_terminal
    path = tmp_path / "short.toml"
    path.write_text(straight_line_toml("short", duration_s=8.0, line_m=1.6))  # the goal at 4 s (8 samples), 16 allowed
    res, lines = gpcnav_on_a_terminal("simulate", path, "--controller", "blind", "--animate", tmp_path / "a.gif")
    assert res.returncode == 0 and "reached_goal" in res.stdout and "steps 8" in res.stdout
    last = {m.group(1): m.group(2) for m in (re.match(r"(simulating|animating): +100%\|.*\| (\d+/\d+)", ln)
                                                for ln in lines) if m}
    assert last == {"simulating": "8/8", "animating": "9/9"}, lines[-4:]
    quiet = run_cli("simulate", path, "--controller", "blind")  # not a terminal: no bar
    assert quiet.returncode == 0 and quiet.stderr == ""


def test_simulate_bad_options_exit_2(tmp_path):
    res = run_cli("simulate", PAPER_DIR / "fig7_1_head_on.toml", "--preset", "paper", "--sample-time", "-1")
    assert res.returncode == 2 and len(res.stderr.splitlines()) == 1 and "--sample-time" in res.stderr
    res = run_cli("simulate", PAPER_DIR / "fig7_1_head_on.toml", "--preset", "nosuch")
    assert res.returncode == 2 and "Traceback" not in res.stderr


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_paper_scenarios_reach_the_goal_without_collision_or_stopping(name):
    """Issue 2's must-show: each Fig. 7 scenario, under each preset, reaches the goal, never
    closer than 0.05 m to the obstacle, with no stop longer than 2 s before the goal."""
    results = {}
    for sc in paper_scenarios():
        # the obstacle really is in the way: a robot on the reference point would hit it
        ts = np.linspace(0.0, sc.duration_s, 4001)
        ref, (ox, oy, _) = sc.reference.pose_at_time(ts), sc.moving[0].state_at(ts)
        assert np.min(np.hypot(ref[:, 0] - ox, ref[:, 1] - oy)) < sc.robot.radius_m + sc.moving[0].radius_m
        doc = run_document(simulate(sc, GPCController(PRESETS[name], sc.robot), "gpc"))
        check_run_document(doc)
        results[sc.name] = (doc["outcome"], round(doc["min_clearance_m"], 3), doc["longest_stop_s"],
                            doc["fallbacks"])
        assert doc["outcome"] == "reached_goal", results
        assert not doc["collided"]
        assert doc["min_clearance_m"] > 0.05, results
        assert doc["longest_stop_s"] <= 2.0, results
        assert np.isfinite(doc["compute_time_s"]["median"]) and doc["compute_time_s"]["median"] > 0
    assert len(results) == 3


def test_run_json_records_the_sensing_seed_simulate_ran_with(tmp_path):
    """simulate --seed S overrides the file's sensing seed; RUN.json says which seed ran (until
    2026-12-02 it said none, so a run with --seed 2 could not be told from one with the file's 0)."""
    scene = PAPER_DIR / "fig7_2_crossing.toml"
    docs = {}
    for seed in (None, 2):
        out = tmp_path / f"run-{seed}.json"
        res = run_cli("simulate", scene, "--controller", "nn", "--out", out, *(["--seed", seed] if seed else []))
        assert res.returncode == 0, res.stderr
        docs[seed] = json.loads(out.read_text())
    file_sensing = paper_scenarios()[1].sensing
    assert docs[None]["sensing"] == {"position_noise_std_m": file_sensing.position_noise_std_m,
                                     "seed": file_sensing.seed, "range_m": None}
    assert docs[2]["sensing"]["seed"] == 2 and file_sensing.seed != 2
    assert docs[2]["trajectory"] != docs[None]["trajectory"]  # the seed is what differs


def test_a_path_as_long_as_a_file_may_have_is_drawn_with_a_bounded_number_of_points(tmp_path):
    """A 1e9 m line (the loader's largest length) made simulate ask for 1e10 points of the path
    for RUN.json's reference_path: numpy's MemoryError, a traceback, exit 1."""
    scene = tmp_path / "long.toml"
    scene.write_text(straight_line_toml(name="long", duration_s=2.0, line_m=1e9), encoding="utf-8")
    out = tmp_path / "run.json"
    res = run_cli("simulate", scene, "--controller", "nn", "--out", out)
    assert res.returncode == 0, res.stderr
    path = json.loads(out.read_text())["reference_path"]
    assert len(path) <= 20001 and path[0] == [0.0, 0.0] and path[-1][0] == pytest.approx(1e9)
