"""The ``gpcnav`` command line: the one place that wires the packages together."""
import sys as _sys

__version__ = "0.1.0"

if "gymnasium" in _sys.modules:
    # gymnasium.make("gpcnav:gpcnav/Navigation-v0") imports this package: register the
    # environment then (Gymnasium >= 1.0 no longer loads the gymnasium.envs entry point).
    from . import gym_env as _gym_env  # noqa: F401
