"""scenarios.paired and tools/paired.py: the episodes that changed outcome between two runs of
the same episodes, and the exact sign test of the split."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from scenarios.paired import outcome_changes, run_changes, sign_test

ROOT = Path(__file__).resolve().parents[1]
TOOL = str(ROOT / "tools" / "paired.py")


def _rows(outcomes: list[str], names=None) -> list[dict]:
    return [{"scenario": f"s{i}" if names is None else names[i], "outcome": o} for i, o in enumerate(outcomes)]


def _eval(path: Path, outcomes: list[str], **source) -> Path:
    path.write_text(json.dumps({"episodes_detail": _rows(outcomes), **source}))
    return path


def _ucy(seed: int, count: int = 2) -> dict:
    """What ``gpcnav evaluate --suite ucy`` records of its suite (the episode names are the
    recorded cases', whatever the seed)."""
    return {"suite": "ucy", "seed": seed, "suite_spec": {"suite": "ucy", "count": count, "seed": seed,
                                                         "behaviour": "replay", "cases": 452}}


def test_changes_are_counted_both_ways_episode_by_episode():
    base = _rows(["reached_goal", "timed_out", "collided", "reached_goal"])
    new = _rows(["timed_out", "reached_goal", "reached_goal", "reached_goal"])
    assert outcome_changes(base, new) == {"reached_goal": (2, 1), "collided": (0, 1)}
    # a suite may name a scenario twice: rows pair by place, not by name
    twice = ["a", "a"]
    assert outcome_changes(_rows(["collided", "reached_goal"], twice),
                           _rows(["reached_goal", "reached_goal"], twice)) == {"reached_goal": (1, 0),
                                                                                "collided": (0, 1)}


def test_the_sign_test_is_the_exact_binomial():
    # 5 changes all one way: twice 0.5^5; 1 against 3: twice P(X <= 1) of Binomial(4, 0.5) = 2 * 5 / 16
    assert sign_test(5, 0) == pytest.approx(2 * 0.5 ** 5)
    assert sign_test(1, 3) == pytest.approx(2 * 5 / 16)
    assert sign_test(4, 4) == pytest.approx(1.0)
    assert sign_test(0, 0) == 1.0


@pytest.mark.parametrize("other, words", [(_rows(["collided"] * 3), "2 against 3"),
                                           (_rows(["collided"] * 2, ["s0", "x"]), "episode 1 is 's1'")])
def test_other_episodes_are_refused(other, words):
    with pytest.raises(ValueError, match=words):
        outcome_changes(_rows(["collided"] * 2), other)


@pytest.mark.slow  # 9 s: four runs of the tool in subprocesses
def test_the_command_line(tmp_path):
    a = _eval(tmp_path / "a.json", ["reached_goal"] * 6 + ["collided"] * 4)
    b = _eval(tmp_path / "b.json", ["reached_goal"] * 10)
    out = subprocess.run([sys.executable, TOOL, str(a), str(b), str(a), str(b)],
                         capture_output=True, text=True, check=True).stdout.splitlines()
    assert out[0] == "a.json -> b.json (10 episodes): reached_goal: +4 -0 (p = 0.125); collided: +0 -4 (p = 0.125)"
    assert out[-1].startswith("all pairs (20 episodes): reached_goal: +8 -0 (p = 0.00781)")
    bad = subprocess.run([sys.executable, TOOL, str(a)], capture_output=True, text=True)
    assert bad.returncode == 2 and "usage" in bad.stderr
    for other in (tmp_path / "no.json", _eval(tmp_path / "c.json", ["collided"] * 3)):
        r = subprocess.run([sys.executable, TOOL, str(a), str(other)], capture_output=True, text=True)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1


def test_runs_of_other_cases_are_refused_though_their_names_agree():
    """Two runs were paired by their episodes' names alone: ``ucy`` under two seeds (other
    sensor noise under the same case names: ``--count 1`` gives students003-across-back-031
    under seeds 0 and 2) or a suite's run against files of the same names counted as one
    episode run twice."""
    names = ["crowds_zara02-along-back-015", "students003-along-back-000"]
    base = {"episodes_detail": _rows(["collided", "reached_goal"], names), **_ucy(1)}
    new = {"episodes_detail": _rows(["reached_goal", "reached_goal"], names), **_ucy(2)}
    with pytest.raises(ValueError, match=r"^not the same episodes: the suites differ in seed 1 against 2$"):
        run_changes(base, new)
    files = {"episodes_detail": new["episodes_detail"], "suite": None, "seed": None}
    with pytest.raises(ValueError, match=r"^not the same episodes: scenario files in one run, suite 'ucy' in the"):
        run_changes(base, files)
    old = {"episodes_detail": new["episodes_detail"], "suite": "ucy", "seed": 2}  # an EVAL without suite_spec
    with pytest.raises(ValueError, match=r"^not the same episodes: the suites differ in seed 1 against 2$"):
        run_changes(base, old)
    assert run_changes(base, {**old, "seed": 1})["reached_goal"] == (1, 0)  # what it records agrees
    # the same cases: the same suite settings, or both files
    assert run_changes(base, {**new, **_ucy(1)}) == {"reached_goal": (1, 0), "collided": (0, 1)}
    assert run_changes({**files, "episodes_detail": base["episodes_detail"]}, files)["collided"] == (0, 1)


def test_the_command_line_refuses_runs_of_other_cases(tmp_path, capsys):
    """tools/paired.py: one line and exit 2 (run in this process: its main)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("paired_tool", TOOL)
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    a = _eval(tmp_path / "a.json", ["collided", "reached_goal"], **_ucy(1))
    b = _eval(tmp_path / "b.json", ["reached_goal", "reached_goal"], **_ucy(2))
    assert tool.main([str(a), str(b)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"{a} / {b}: ValueError: not the same episodes: the suites differ in seed 1 against 2"]
    c = _eval(tmp_path / "c.json", ["reached_goal", "reached_goal"], **_ucy(1))
    assert tool.main([str(a), str(c)]) == 0
    assert capsys.readouterr().out.startswith("a.json -> c.json (2 episodes): reached_goal: +1 -0")
