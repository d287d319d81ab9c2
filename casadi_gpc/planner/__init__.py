"""The GPC planner: ``gpc`` (:class:`GPCController`: estimate, select, solve from several
starts, fall back), ``guesses`` (the multi-start's initial guesses), ``candidates`` (the
persistent candidates kept from tick to tick) and ``lanes`` (a tick's starts solved at once
in threads). It sits above :mod:`casadi_gpc.problem` and :mod:`casadi_gpc.solvers`.

Imports CasADi; ``GPCController`` is loaded on first use so that this package's name
imports without it.
"""
__all__ = ["GPCController"]


def __getattr__(name):
    if name == "GPCController":
        from .gpc import GPCController
        return GPCController
    raise AttributeError(name)
