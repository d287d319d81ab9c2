"""The contract's Gymnasium registration, each in a fresh interpreter (nothing of gpcnav
imported before): ``gymnasium.make("gpcnav:gpcnav/Navigation-v0")`` by id alone, with no
keyword argument, passes Gymnasium's ``check_env`` and reproduces a seeded reset;
``import gpcnav`` registers the plain id without importing the environment or the planner;
``import gpcnav`` works without Gymnasium; the extras admit Gymnasium 1.x and declare no
``gymnasium.envs`` entry point (1.0 no longer reads them)."""
from __future__ import annotations

import os
import subprocess
import sys
import tomllib

import pytest

gymnasium = pytest.importorskip("gymnasium")

from conftest import REPO  # noqa: E402

MAKE_BY_ID = """
import sys, warnings
import numpy as np
import gymnasium
from gymnasium.utils.env_checker import check_env
assert "gpcnav" not in sys.modules
warnings.simplefilter("error")
env = gymnasium.make("gpcnav:gpcnav/Navigation-v0")
check_env(env.unwrapped, skip_render_check=True)
runs = []
for seed in (11, 11, 12):
    obs, info = env.reset(seed=seed)
    trace = [obs]
    for _ in range(4):
        obs, reward, terminated, truncated, info = env.step(np.array([0.3, 0.32], dtype=np.float32))
        trace.append(obs)
    runs.append((info["scenario"], np.stack(trace)))
same = runs[0][0] == runs[1][0] and np.array_equal(runs[0][1], runs[1][1])
print(type(env.unwrapped).__name__, env.unwrapped.suite.name, env.unwrapped.suite.movers, obs.shape, same,
      runs[2][0] != runs[0][0], gymnasium.__version__.split(".")[0])
"""


def _run(code: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=REPO,
                          env=env)


def test_make_by_id_alone_with_no_keyword_passes_check_env_and_reproduces_a_seed():
    r = _run(MAKE_BY_ID)
    assert r.returncode == 0, r.stderr[-3000:]
    name, suite, movers, shape, same, differs, major = r.stdout.split()
    assert (name, suite, movers, shape) == ("NavigationEnv", "circle-crossing", "5", "(58,)")
    assert same == "True" and differs == "True"
    assert int(major) >= 1


def test_import_gpcnav_registers_the_plain_id_and_imports_nothing_heavy():
    code = ("import sys\nimport gpcnav\nimport gymnasium\n"
            "assert gpcnav.ENV_ID in gymnasium.registry\n"
            "heavy = [m for m in ('gpcnav.gym_env', 'scenarios', 'casadi', 'onnxruntime', 'torch')\n"
            "         if m in sys.modules]\n"
            "env = gymnasium.make('gpcnav/Navigation-v0', suite='random')\n"
            "obs, info = env.reset(seed=0)\n"
            "print(heavy, type(env.unwrapped).__name__, info['scenario'].startswith('random'))\n")
    r = _run(code)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.split() == ["[]", "NavigationEnv", "True"]


def test_import_gpcnav_needs_no_gymnasium():
    code = ("import sys\nsys.modules['gymnasium'] = None  # Python's way to make a module unimportable\n"
            "import gpcnav\nprint(gpcnav.ENV_ID)\n")
    r = _run(code)
    assert r.returncode == 0, r.stderr[-3000:]
    assert r.stdout.strip() == "gpcnav/Navigation-v0"


def test_the_extras_admit_the_installed_gymnasium_1x_and_no_entry_point_is_declared():
    from packaging.requirements import Requirement
    meta = tomllib.loads((REPO / "pyproject.toml").read_text())
    installed = gymnasium.__version__
    assert int(installed.split(".")[0]) >= 1
    for extra in ("gym", "test"):
        reqs = [Requirement(r) for r in meta["project"]["optional-dependencies"][extra]]
        gym = [r for r in reqs if r.name == "gymnasium"]
        assert len(gym) == 1 and gym[0].specifier.contains(installed) and not gym[0].specifier.contains("0.29.1")
    assert "gymnasium.envs" not in meta["project"].get("entry-points", {})
