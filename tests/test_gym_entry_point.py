"""The ``gymnasium.envs`` entry point for real (slow, needs PyPI): a throwaway virtual
environment with the project installed from a copy of this checkout and Gymnasium 0.29.1,
the last release that loads such entry points at ``import gymnasium``; there
``gymnasium.make("gpcnav/Navigation-v0")`` works with no other import. (Gymnasium >= 1.0,
which the project otherwise uses, removed that loading: docs/peers.md.)"""
from __future__ import annotations

import shutil
import site
import subprocess
import sys

import pytest

from conftest import REPO

pytestmark = pytest.mark.slow

CODE = """
import gymnasium
env = gymnasium.make("gpcnav/Navigation-v0", suite="circle-crossing", movers=3)
obs, info = env.reset(seed=0)
print(gymnasium.__version__, type(env.unwrapped).__name__, obs.shape, info["outcome"])
"""


def test_gymnasium_0_29_loads_the_entry_point(tmp_path):
    src = tmp_path / "src"
    shutil.copytree(REPO, src, ignore=shutil.ignore_patterns(".git", "out", "build", "*.egg-info", "__pycache__",
                                                              ".pytest_cache", ".hypothesis", ".venv"))
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=120)
    py = venv / "bin" / "python"
    purelib = subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_path('purelib'))"],
                             capture_output=True, text=True, check=True).stdout.strip()
    # everything else (numpy, casadi, navground, ...) from the environment running the tests
    (tmp_path / "venv" / purelib.split(str(venv) + "/", 1)[1] / "outer.pth").write_text(
        "\n".join(site.getsitepackages()) + "\n")
    for args in (["gymnasium==0.29.1"], [str(src)]):
        r = subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", *args], capture_output=True,
                           text=True, timeout=600)
        if r.returncode != 0 and "gymnasium" in args[0]:
            pytest.skip(f"cannot install gymnasium 0.29.1 here: {r.stderr.strip().splitlines()[-1:]}")
        assert r.returncode == 0, r.stderr[-2000:]
    r = subprocess.run([str(py), "-c", CODE], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["0.29.1", "NavigationEnv", "(58,)", "running"]
