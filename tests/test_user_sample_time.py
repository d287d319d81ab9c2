"""A user's controller whose sample_time_s is a numpy number (np.float32(0.5), np.int64(1)): it was
refused as "not a positive number of seconds" (found by the contract hunt); any finite positive
real is taken, and the documents record it as a plain number."""
import json
import os
import subprocess
import sys
import textwrap

import pytest

from conftest import REPO

MODULE = textwrap.dedent('''
    import numpy as np
    from casadi_gpc import ControlDecision

    class Float32:
        sample_time_s = np.float32(0.5)
        def reset(self):
            pass
        def decide(self, observation):
            v = observation.reference.speed_mps
            return ControlDecision(v, v)

    class Int64(Float32):
        sample_time_s = np.int64(1)

    class Negative(Float32):
        sample_time_s = np.float32(-0.5)

    class Tiny(Float32):
        sample_time_s = 1e-9
''')


def _cli(cwd, *args):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", "gpcnav", *map(str, args)], capture_output=True, text=True,
                          timeout=300, cwd=cwd, env=env)


@pytest.mark.parametrize("name, seconds", [("Float32", 0.5), ("Int64", 1.0)])
def test_a_numpy_sample_time_runs_and_is_recorded_as_a_number(tmp_path, name, seconds):
    (tmp_path / "npmod.py").write_text(MODULE, encoding="utf-8")
    scene = REPO / "scenarios" / "paper" / "fig7_2_crossing.toml"
    r = _cli(tmp_path, "evaluate", scene, "--controller", f"npmod:{name}", "--workers", "1", "--out", "e.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((tmp_path / "e.json").read_text())
    assert doc["sample_time_s"] == seconds and type(doc["controller_settings"]["sample_time_s"]) is float


def test_a_negative_numpy_sample_time_is_still_refused(tmp_path):
    (tmp_path / "npmod.py").write_text(MODULE, encoding="utf-8")
    scene = REPO / "scenarios" / "paper" / "fig7_2_crossing.toml"
    r = _cli(tmp_path, "evaluate", scene, "--controller", "npmod:Negative", "--workers", "1", "--out", "e.json")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "sample_time_s must be a positive" \
        in r.stderr
    assert not (tmp_path / "e.json").exists()


def test_a_sample_time_below_the_command_lines_shortest_is_refused(tmp_path):
    """1e-9 s was taken (forty billion decisions for a 40 s scene): a user's class gets the rule
    of --sample-time and --set sample_time_s, at least 0.05 s, in one line before any episode."""
    (tmp_path / "npmod.py").write_text(MODULE, encoding="utf-8")
    scene = REPO / "scenarios" / "paper" / "fig7_2_crossing.toml"
    r = _cli(tmp_path, "simulate", scene, "--controller", "npmod:Tiny", "--out", "r.json")
    assert r.returncode == 2 and r.stderr.strip().splitlines() == [
        "gpcnav simulate: error: --controller npmod:Tiny: sample_time_s must be at least 0.05 s, as --sample-time's, "
        "got 1e-09 (one decision per sample)"], r.stderr
    assert not (tmp_path / "r.json").exists()
