"""Commands beyond the robot's limits, which the simulator clips, are counted in EVAL.json (its
``events``, summed over the episodes) as RUN.json counts them (``clipped_commands``): until
2026-12-02 an evaluation of a controller whose every command was clipped said nothing of it."""
import json
import os
import subprocess
import sys
import textwrap

from conftest import REPO, straight_line_toml

MODULE = textwrap.dedent('''
    from casadi_gpc import ControlDecision

    class TooFast:
        sample_time_s = 0.5
        def reset(self):
            pass
        def decide(self, observation):
            return ControlDecision(v_right_mps=5.0, v_left_mps=5.0)
''')

SCENE = straight_line_toml("short", duration_s=2.0, line_m=3.0)


def _cli(cwd, *args):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", "gpcnav", *map(str, args)], capture_output=True, text=True,
                          timeout=300, cwd=cwd, env=env)


def test_evaluate_counts_the_commands_the_simulator_clipped(tmp_path):
    (tmp_path / "fastmod.py").write_text(MODULE, encoding="utf-8")
    (tmp_path / "short.toml").write_text(SCENE, encoding="utf-8")
    r = _cli(tmp_path, "evaluate", "short.toml", "short.toml", "--controller", "fastmod:TooFast", "--workers", "1",
             "--out", "e.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "e.json").read_text())
    steps = sum(e["steps"] for e in doc["episodes_detail"])
    assert steps == 8 and doc["events"]["clipped_commands"] == steps  # two episodes of four decisions, all clipped
