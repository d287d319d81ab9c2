"""The contract's ``gymnasium.make("gpcnav/Navigation-v0")`` with no other import.

The package declares a ``gymnasium.envs`` entry point; Gymnasium 0.26 to 0.29 load such entry
points at ``import gymnasium`` (1.0 removed the loading, which is why the ``gym`` and ``test``
extras pin ``gymnasium<1.0``). The test runs a fresh interpreter, so nothing of gpcnav is
imported before ``gymnasium.make``: it fails if the entry point is not declared, not installed
(``pip install -e ".[test]"``), or Gymnasium no longer loads it."""
from __future__ import annotations

import subprocess
import sys
from importlib import metadata

CODE = """
import sys
import gymnasium
assert "gpcnav.gym_env" in sys.modules, "import gymnasium did not load the entry point"
env = gymnasium.make("gpcnav/Navigation-v0", suite="circle-crossing", movers=3)
obs, info = env.reset(seed=0)
obs, reward, terminated, truncated, info = env.step([0.2, 0.2])
print(type(env.unwrapped).__name__, obs.shape, info["outcome"], terminated, truncated)
"""


def test_the_entry_point_is_declared_by_the_installed_package():
    eps = [ep for ep in metadata.entry_points(group="gymnasium.envs") if ep.name == "gpcnav"]
    assert [ep.value for ep in eps] == ["gpcnav.gym_env:register_envs"], \
        "reinstall the project (pip install -e .) so its entry points are current"


def test_gymnasium_make_with_the_plain_id_in_a_fresh_process(tmp_path):
    import gymnasium
    assert int(gymnasium.__version__.split(".")[0]) < 1, \
        f"Gymnasium {gymnasium.__version__} does not load entry points; the extras pin <1.0"
    r = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.split() == ["NavigationEnv", "(58,)", "running", "False", "False"]
