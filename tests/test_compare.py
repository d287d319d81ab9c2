"""``gpcnav compare``: every controller on the very same episodes, one EVAL document each
(the same as ``evaluate`` gives), the table and the figure beside the JSON."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from conftest import REPO, straight_line_toml

CROSSING = """[[moving_obstacles]]
position = [2.0, -2.0]
heading_deg = 90.0
speed_mps = 0.35
radius_m = 0.3
"""

STRAIGHT = '''
from casadi_gpc import ControlDecision

class Straight:
    sample_time_s = 0.5
    def reset(self):
        pass
    def decide(self, observation):
        return ControlDecision(0.4, 0.4)
'''

EVAL_KEYS = ("controller", "episodes", "success_rate", "collision_rate", "timeout_rate", "min_clearance_m",
             "tracking_rmse_m", "compute_time_s", "episodes_detail", "time_to_goal_s", "danger_rate",
             "min_clearance_in_danger_m", "path_length_m", "collision_rate_upper_95", "failure_rate_upper_95",
             "interventions")


def _cli(cwd, *args):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", "gpcnav", *map(str, args)], capture_output=True, text=True,
                          timeout=600, cwd=cwd, env=env)


@pytest.fixture(scope="module")
def compared(tmp_path_factory):
    d = tmp_path_factory.mktemp("compare")
    (d / "straight.py").write_text(STRAIGHT, encoding="utf-8")
    files = []
    for name, extra in (("free", ""), ("crossing", CROSSING)):
        files.append(d / f"{name}.toml")
        files[-1].write_text(straight_line_toml(name, extra=extra), encoding="utf-8")
    r = _cli(d, "compare", *files, "--controllers", "orca,straight:Straight,hrvo", "--workers", "2",
             "--out", d / "out" / "C.json")
    assert r.returncode == 0, r.stderr
    return d, files, json.loads((d / "out" / "C.json").read_text()), r.stdout


def test_compare_writes_one_eval_per_controller_on_the_same_episodes(compared):
    d, files, doc, stdout = compared
    assert [e["controller"] for e in doc["controllers"]] == ["orca", "straight:Straight", "hrvo"]
    assert doc["scenarios"] == ["free", "crossing"]
    for e in doc["controllers"]:
        assert all(k in e for k in EVAL_KEYS)
        assert [x["scenario"] for x in e["episodes_detail"]] == ["free", "crossing"]
    # known answers: driving straight at the reference speed reaches the free goal at 10 s
    # and runs into the mover crossing at x = 2 m; the peers avoid it
    straight = doc["controllers"][1]["episodes_detail"]
    assert [x["outcome"] for x in straight] == ["reached_goal", "collided"]
    assert straight[0]["time_to_goal_s"] == pytest.approx(10.0)
    for e in (doc["controllers"][0], doc["controllers"][2]):
        assert e["success_rate"] == 1.0 and e["controller_settings"]["sample_time_s"] == 0.1
    # the table beside the JSON (and on stdout), a row per controller, and the figure
    table = (d / "out" / "C.md").read_text()
    assert table.strip() == stdout.strip()
    table, paired = table.split("\n\nEpisode by episode against orca")
    rows = [line for line in table.splitlines() if line.startswith("| ") and "controller" not in line]
    assert [r.split("|")[1].strip() for r in rows] == ["orca", "straight:Straight", "hrvo"]
    # under it, each against the first: straight lost the crossing orca reached, by a collision
    assert "| straight:Straight | 0 / 1 (1) | 1 / 0 (1) |" in paired and "| hrvo | 0 / 0 (1) | 0 / 0 (1) |" in paired
    assert "| 50.0 (>= " in rows[1]
    assert (d / "out" / "C.png").stat().st_size > 10_000


def test_compare_gives_what_evaluate_gives(compared):
    d, files, doc, _ = compared
    r = _cli(d, "evaluate", *files, "--controller", "hrvo", "--workers", "1", "--out", d / "hrvo.json")
    assert r.returncode == 0, r.stderr
    alone = json.loads((d / "hrvo.json").read_text())
    together = doc["controllers"][2]
    for a, b in zip(alone["episodes_detail"], together["episodes_detail"]):
        assert (a["outcome"], a["min_clearance_m"], a["time_to_goal_s"], a["steps"]) == \
               (b["outcome"], b["min_clearance_m"], b["time_to_goal_s"], b["steps"])


def test_compare_refuses_a_bad_controller_before_any_work(compared):
    d, files, _, _ = compared
    r = _cli(d, "compare", files[0], "--controllers", "orca,nosuch:Thing", "--out", d / "bad.json")
    assert r.returncode == 2 and "nosuch" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert not (d / "bad.json").exists()


def test_the_figure_has_a_row_per_controller_on_each_panel():
    from gpcnav.commands.compare_report import compare_figure, compare_table
    detail = [{"time_to_goal_s": 20.0}, {"time_to_goal_s": None}]
    evals = [{"controller": n, "episodes": 2, "success_rate": s, "collision_rate": c, "timeout_rate": 0.0,
              "failure_rate_upper_95": 0.9, "collision_rate_upper_95": 0.8, "episodes_detail": detail,
              "compute_time_s": {"median": m, "p95": 2 * m, "max": 3 * m}, "time_to_goal_s": None,
              "min_clearance_m": {"min": 0.1, "median": 0.2}, "danger_rate": 0.0, "path_length_m": {"median": 8.0},
              "fallbacks": 0} for n, s, c, m in (("a", 0.5, 0.5, 1e-4), ("b", 1.0, 0.0, 1e-2))]
    doc = {"controllers": evals, "preset": "improved", "suite_spec": None}
    fig = compare_figure(doc)
    assert len(fig.axes) == 4
    assert [t.get_text() for t in fig.axes[0].get_yticklabels()] == ["a", "b"]
    assert fig.axes[3].get_xscale() == "log"
    assert compare_table(doc).count("\n| ") == 3  # header and two rows


def test_the_paired_table_counts_each_controller_against_the_first():
    """Under COMPARE.md's table: per controller after the first, the episodes it reached (or
    collided in) and the first did not, and the other way round, with the exact sign test."""
    from gpcnav.commands.compare_report import paired_table
    from scenarios.paired import sign_test

    def ev(name, outcomes):
        return {"controller": name, "episodes_detail": [{"scenario": f"s{i}", "outcome": o}
                                                         for i, o in enumerate(outcomes)]}
    first = ev("gpc", ["reached_goal", "reached_goal", "collided", "timed_out", "reached_goal"])
    second = ev("orca", ["reached_goal", "timed_out", "reached_goal", "reached_goal", "collided"])
    third = ev("stand", ["collided"] * 5)
    table = paired_table({"controllers": [first, second, third]}).splitlines()
    assert table[0].startswith("Episode by episode against gpc")
    assert table[-2] == f"| orca | 2 / 2 ({sign_test(2, 2):.2g}) | 1 / 1 ({sign_test(1, 1):.2g}) |"
    assert table[-1] == f"| stand | 0 / 3 ({sign_test(0, 3):.2g}) | 4 / 0 ({sign_test(4, 0):.2g}) |"
    assert sign_test(4, 0) == 0.125
    assert paired_table({"controllers": [first]}) == ""  # nothing to pair
    assert paired_table({"controllers": [first, {"controller": "x", "episodes_detail": [{}] * 5}]}) == ""


@pytest.mark.parametrize("option", [["--model", "net.onnx"], ["--passes", "1"]])
def test_compare_refuses_the_network_s_options_without_nn_among_the_controllers(tmp_path, capsys, option):
    """``compare --controllers stand,blind --model M.onnx`` ran, and the model was dropped without a word
    (``simulate`` and ``evaluate`` refuse ``--model`` for another controller than nn); now one line, exit 2."""
    from gpcnav.cli import main
    scene = tmp_path / "free.toml"
    scene.write_text(straight_line_toml("free"), encoding="utf-8")
    code = main(["compare", str(scene), "--controllers", "stand,blind", *option, "--workers", "1",
                 "--out", str(tmp_path / "C.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and option[0] in err[0] and "nn" in err[0], err
    assert not (tmp_path / "C.json").exists()


def test_the_caption_tells_replayed_people_from_walkers():
    """COMPARE.md's and COMPARE.png's caption names the recorded suite's behaviour: `ucy` replayed
    and `ucy --behaviour orca` are different episodes (until 2026-12-02 both read "suite ucy, seed 1")."""
    from gpcnav.commands.compare_report import episodes_caption
    from scenarios.suites import Suite

    def caption(behaviour):
        spec = Suite("ucy", count=3, seed=1, behaviour=behaviour).describe()
        return episodes_caption({"controllers": [{"episodes": 3}], "preset": "improved", "suite_spec": spec})
    assert caption("replay") == "3 episodes (suite ucy, seed 1, replay), preset improved"
    assert caption("orca") == "3 episodes (suite ucy, seed 1, orca), preset improved"
    crowd = Suite("circle-crossing", count=4, seed=1, behaviour="orca").describe()
    assert episodes_caption({"controllers": [{"episodes": 4}], "preset": "improved", "suite_spec": crowd}) == \
        "4 episodes (suite circle-crossing, seed 1, 5 orca movers), preset improved"
