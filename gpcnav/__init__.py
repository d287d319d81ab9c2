"""The ``gpcnav`` command line: the one place that wires the packages together.

Importing the package registers ``gpcnav/Navigation-v0`` with Gymnasium when Gymnasium is
installed (Gymnasium's own convention since 1.0, which no longer reads plugin entry points):
the id points at :class:`gpcnav.gym_env.NavigationEnv` by name, so neither that module nor
the planner is imported until an environment is made. Without Gymnasium nothing happens.
"""
from importlib.util import find_spec as _find_spec

__version__ = "0.1.0"

ENV_ID = "gpcnav/Navigation-v0"
"""The Gymnasium id of :class:`gpcnav.gym_env.NavigationEnv`."""


def register_envs() -> None:
    """Register :data:`ENV_ID` with Gymnasium (once; done at ``import gpcnav``)."""
    import gymnasium
    if ENV_ID not in gymnasium.registry:
        gymnasium.register(id=ENV_ID, entry_point="gpcnav.gym_env:NavigationEnv")


def _gymnasium_installed() -> bool:
    try:
        return _find_spec("gymnasium") is not None
    except (ImportError, ValueError):  # made unimportable on purpose (sys.modules entry None)
        return False


if _gymnasium_installed():
    try:
        register_envs()
    except ImportError:  # a broken Gymnasium must not break the planner's users
        pass
