"""tools/noise_repeats.py: the same scenario files with only the sensor's seed changed, run
again, and how many episodes kept their outcome."""
from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from scenarios import load_scenario

ROOT = Path(__file__).resolve().parents[1]
TOOL = ROOT / "tools" / "noise_repeats.py"
PAPER = ROOT / "scenarios" / "paper" / "fig7_1_head_on.toml"
_spec = importlib.util.spec_from_file_location("noise_repeats", TOOL)
nr = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(nr)


def _variants(tmp_path: Path) -> dict[str, Path]:
    """The paper's head-on file with its sensing as a file may hold it: a seed (and a comment),
    a table without a seed, no table."""
    base = PAPER.read_text()
    assert "[sensing]" not in base
    texts = {"seeded": base + "\n[sensing]\nposition_noise_std_m = 0.05\nseed = 7   # the noise's\n\n[faults]\n",
             "unseeded": base + "\n[sensing]\nposition_noise_std_m = 0.05\n",
             "none": base}
    out = {}
    for k, t in texts.items():
        out[k] = tmp_path / f"{k}.toml"
        out[k].write_text(t)
    return out


def test_only_the_sensor_seed_changes_whatever_the_file_holds(tmp_path):
    for kind, path in _variants(tmp_path).items():
        before = load_scenario(path)
        text = nr.with_sensor_seed(path.read_text(), 123456)
        path.with_suffix(".new.toml").write_text(text)
        after = load_scenario(path.with_suffix(".new.toml"))
        assert after.sensing.seed == 123456, kind
        # everything else the same scenario, field by field
        assert replace(after, sensing=replace(after.sensing, seed=before.sensing.seed), source=before.source) == before, \
            kind
        if kind == "seeded":
            assert "seed = 123456   # the noise's" in text and text.count("seed =") == 1


@pytest.mark.slow  # kept out of the default suite for its time (CI: under 10 minutes)
def test_two_runs_differ_in_their_noise_and_the_summary_counts_them(tmp_path):
    files = [_variants(tmp_path)["seeded"], _variants(tmp_path)["none"]]
    done = subprocess.run([sys.executable, str(TOOL), *map(str, files), "--out", str(tmp_path / "rep"), "--repeats",
                           "2", "--", "--controller", "gpc", "--workers", "1"], capture_output=True, text=True,
                          cwd=ROOT)
    assert done.returncode == 0, done.stderr
    s = json.loads((tmp_path / "rep" / "SUMMARY.json").read_text())
    docs = [json.loads((tmp_path / "rep" / f"run-{r}" / "EVAL.json").read_text()) for r in (0, 1)]
    assert [load_scenario(tmp_path / "rep" / "run-1" / f.name).sensing.seed for f in files] == \
        [7 + nr.SEED_STEP, 0 + nr.SEED_STEP]
    assert [load_scenario(tmp_path / "rep" / "run-0" / f.name).sensing.seed for f in files] == [7, 0]
    for d, counts in zip(docs, s["runs"]):
        assert counts == {k: sum(e["outcome"] == k for e in d["episodes_detail"])
                          for k in ("reached_goal", "collided", "timed_out")}
    outcomes = [[e["outcome"] for e in d["episodes_detail"]] for d in docs]
    assert s["episodes"] == 2 and s["same_outcome_in_every_run"] == sum(a == b for a, b in zip(*outcomes))
    # the noise was drawn again: the planner's path is not the same to the last digit
    a, b = ([e["tracking_rmse_m"] for e in d["episodes_detail"]] for d in docs)
    assert a != b
    assert f"{s['same_outcome_in_every_run']} of 2 episodes" in done.stdout


def test_a_bad_file_is_one_line_and_exit_2(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("name = 'x'\n")
    done = subprocess.run([sys.executable, str(TOOL), str(bad), "--out", str(tmp_path / "o")], capture_output=True,
                          text=True, cwd=ROOT)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1 and "bad.toml" in done.stderr
    done = subprocess.run([sys.executable, str(TOOL), str(PAPER), "--out", str(tmp_path / "o"), "--repeats", "1"],
                          capture_output=True, text=True, cwd=ROOT)
    assert done.returncode == 2 and "--repeats" in done.stderr


@pytest.mark.parametrize("docs", [[{"episodes_detail": [{"scenario": "a", "outcome": "reached_goal"}]},
                                   {"episodes_detail": [{"scenario": "b", "outcome": "reached_goal"}]}]])
def test_runs_of_other_episodes_are_refused(docs):
    with pytest.raises(ValueError, match="same episodes"):
        nr.summary(docs)
