"""tools/paired.py: the episodes that changed outcome between two runs, and the exact sign test."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tools"))
import paired  # noqa: E402


def _eval(path: Path, outcomes: list[str]) -> Path:
    path.write_text(json.dumps({"episodes_detail": [{"scenario": f"s{i}", "outcome": o}
                                                    for i, o in enumerate(outcomes)]}))
    return path


def test_changes_are_counted_both_ways():
    base = {"a": "reached_goal", "b": "timed_out", "c": "collided", "d": "reached_goal"}
    new = {"a": "timed_out", "b": "reached_goal", "c": "reached_goal", "d": "reached_goal"}
    assert paired.changes(base, new) == {"reached_goal": (2, 1), "collided": (0, 1)}


def test_the_sign_test_is_the_exact_binomial():
    # 5 changes all one way: twice 0.5^5; 3 against 1: twice P(X <= 1) of Binomial(4, 0.5) = 2 * 5 / 16
    assert paired.sign_test(5, 0) == pytest.approx(2 * 0.5 ** 5)
    assert paired.sign_test(1, 3) == pytest.approx(2 * 5 / 16)
    assert paired.sign_test(4, 4) == pytest.approx(1.0)
    assert paired.sign_test(0, 0) == 1.0


def test_other_episodes_are_refused():
    with pytest.raises(ValueError, match="not the same episodes"):
        paired.changes({"a": "collided"}, {"b": "collided"})


def test_the_command_line(tmp_path):
    a = _eval(tmp_path / "a.json", ["reached_goal"] * 6 + ["collided"] * 4)
    b = _eval(tmp_path / "b.json", ["reached_goal"] * 10)
    out = subprocess.run([sys.executable, str(ROOT / "tools" / "paired.py"), str(a), str(b), str(a), str(b)],
                         capture_output=True, text=True, check=True).stdout.splitlines()
    assert out[0] == "a.json -> b.json (10 episodes): reached_goal: +4 -0 (p = 0.125); collided: +0 -4 (p = 0.125)"
    assert out[-1].startswith("all pairs (20 episodes): reached_goal: +8 -0 (p = 0.00781)")
    bad = subprocess.run([sys.executable, str(ROOT / "tools" / "paired.py"), str(a)], capture_output=True, text=True)
    assert bad.returncode == 2 and "usage" in bad.stderr
    missing = subprocess.run([sys.executable, str(ROOT / "tools" / "paired.py"), str(a), str(tmp_path / "no.json")],
                             capture_output=True, text=True)
    assert missing.returncode == 2 and len(missing.stderr.strip().splitlines()) == 1
