"""The deployment path: ``from nn_export import OnnxPolicy`` and a decision work with torch
and casadi made unimportable, and pull in neither."""
from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from nn_export.runtime.policy import shipped_model_path

BLOCKER = textwrap.dedent("""
    import sys

    class _Blocker:
        BLOCKED = ("torch", "casadi", "onnx", "matplotlib", "scipy")

        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in self.BLOCKED:
                raise ImportError(f"{name} is blocked: the deployed policy must not import it")
            return None

    sys.meta_path.insert(0, _Blocker())
""")

SCRIPT = BLOCKER + textwrap.dedent("""
    import numpy as np
    from nn_export import OnnxPolicy
    from casadi_gpc.safety import Shield
    from casadi_gpc.reference import ReferencePath, Segment
    from casadi_gpc.robot import RobotState
    from casadi_gpc.types import Observation, ObstacleMeasurement, StaticObstacle

    for preset in ("paper", "improved"):
        policy = Shield(OnnxPolicy(preset=preset))  # deployed behind the check layer
        T = policy.sample_time_s
        ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(10.0),), 0.4)
        robot = RobotState(0.0, 0.0, 0.0, 0.0, 0.0)
        decisions = []
        for k in range(4):
            obs = Observation(k * T, robot, ref, (ObstacleMeasurement(0, (6.0 - 0.4 * k * T, 0.0), 0.3),),
                              (StaticObstacle((3.0, 1.5), 0.3),))
            d = policy.decide(obs)
            assert np.isfinite(d.v_right_mps) and np.isfinite(d.v_left_mps)
            assert abs(d.v_right_mps) <= 0.8 and abs(d.v_left_mps) <= 0.8
            decisions.append((d.v_right_mps, d.v_left_mps))
        print(preset, decisions[-1])
    # the crowd network's compiled pass reads its weights without the onnx package
    info = OnnxPolicy(preset="improved", compiled_set_networks=True).model_info
    assert info["crowd_model"]["executor"].startswith("compiled"), info["crowd_model"]["executor"]
    for mod in ("torch", "casadi", "onnx", "scipy", "matplotlib"):
        assert mod not in sys.modules, mod
    print("OK")
""")


@pytest.mark.skipif(not shipped_model_path("paper").is_file(), reason="no shipped model yet")
def test_policy_runs_with_torch_and_casadi_blocked():
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().endswith("OK")


def test_the_blocker_really_blocks():
    """The same blocker makes an import of the planner (which needs casadi) fail."""
    out = subprocess.run([sys.executable, "-c", BLOCKER + "import casadi_gpc.planner.gpc"], capture_output=True, text=True,
                         timeout=60)
    assert out.returncode != 0 and "blocked" in out.stderr


def test_deployment_footprint_stays_under_240_mb():
    """tools/footprint.py: a fresh process that imports only the deployed policy (torch and
    casadi blocked), loads the shipped models and makes 1,000 decisions (and 300 among ten
    movers, answered by the crowd network) peaks under 240 MB resident (measured 186 MB: numba
    and llvmlite, which the compiled forecast and check need, are about 124 MB of it; 62 MB
    before them, docs/nn-deploy.md; importing torch alone costs about 220 MB). Memory, not
    time: the process's readiness time is reported by the tool, not asserted here."""
    import importlib.util
    from pathlib import Path
    spec = importlib.util.spec_from_file_location("footprint", Path(__file__).parents[1] / "tools" / "footprint.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    r = mod.measure("improved", 1000)
    assert r["decisions"] == 1000 and not r["torch_loaded"] and not r["casadi_loaded"]
    assert 20.0 < r["peak_rss_mb"] < 240.0, r
    # among ten movers the shipped crowd network answers (a second onnxruntime session)
    r = mod.measure("improved", 300, movers=10)
    assert r["crowd_decisions"] >= 250 and not r["torch_loaded"] and not r["casadi_loaded"]
    assert 20.0 < r["peak_rss_mb"] < 240.0, r


# the command line is the world around the robot (the simulator, the measures: scipy, the plots):
# only the planner's and the trainer's libraries are made unimportable
CLI = BLOCKER.replace('BLOCKED = ("torch", "casadi", "onnx", "matplotlib", "scipy")', 'BLOCKED = ("torch", "casadi")') + \
    textwrap.dedent("""
    from gpcnav.cli import main
    code = main(sys.argv[1:])
    for mod in ("torch", "casadi"):
        assert mod not in sys.modules, mod
    sys.exit(code)
""")


@pytest.mark.skipif(not shipped_model_path("improved").is_file(), reason="no shipped model yet")
def test_evaluate_the_network_without_casadi(tmp_path):
    """``gpcnav evaluate --controller nn`` is what a robot without CasADi runs (the network
    behind the planner-free check): it runs with casadi and torch unimportable (it once
    stopped on an ImportError) and its episodes reach the goal; the GPC on standby
    (``--shield-fallback gpc``) and ``bench`` (it times the GPC) are refused in one line there,
    exit 2."""
    import json
    out = tmp_path / "eval.json"
    args = ["evaluate", "--suite", "circle-crossing", "--movers", "5", "--count", "2", "--seed", "1",
            "--controller", "nn", "--workers", "1", "--out", str(out)]
    run = subprocess.run([sys.executable, "-c", CLI, *args], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    doc = json.loads(out.read_text())
    assert doc["controller"] == "nn" and doc["episodes"] == 2 and doc["success_rate"] == 1.0
    refused = subprocess.run([sys.executable, "-c", CLI, *args[:-2], "--shield-fallback", "gpc"], capture_output=True,
                             text=True, timeout=300)
    assert refused.returncode == 2
    lines = refused.stderr.strip().splitlines()
    assert len(lines) == 1 and "needs the planner" in lines[0], refused.stderr[-2000:]
    bench = subprocess.run([sys.executable, "-c", CLI, "bench", "--no-nn-rows"], capture_output=True, text=True,
                           timeout=300)
    assert bench.returncode == 2 and len(bench.stderr.strip().splitlines()) == 1 and "CasADi" in bench.stderr
