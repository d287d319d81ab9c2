"""tools/rule_table.py: each rule's table.py, now built on it, writes the table it wrote as a
script of its own (the committed table.md, to the character), and its sign test is the exact
binomial tail."""
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
RULES = [("docs/data/pedestrians/sets_off", "seed61"), ("docs/data/pedestrians/fast_walkers", "runs"),
         ("docs/data/deploy/own_threshold", "runs"), ("docs/data/deploy/walls_crowd", "runs")]


@pytest.mark.parametrize("folder,runs", RULES)
def test_a_rule_s_table_is_the_one_recorded(folder, runs):
    d = ROOT / folder
    out = subprocess.run([sys.executable, str(d / "table.py"), str(d / runs)], capture_output=True, text=True,
                         check=True).stdout
    assert out == (d / "table.md").read_text()


def test_the_sign_test_is_the_binomial_tail():
    sys.path.insert(0, str(ROOT / "tools"))
    from rule_table import p_lost
    assert p_lost(1, 3) == pytest.approx(5 / 16)  # P(at least 3 of 4 losses | a fair coin)
    assert p_lost(0, 0) == 1.0 and p_lost(5, 0) == 1.0
