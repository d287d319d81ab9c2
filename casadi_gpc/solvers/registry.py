"""The solvers by name: which exist, their aliases, the fastest, and the backend built for
a problem."""
from __future__ import annotations

from ..problem.cost import GPCProblem
from .base import Backend
from .compiling import while_compiling
from .fatrop import FatropBackend, start_fatrop_library
from .hybrid import HybridBackend
from .ipopt import IpoptBackend, start_ipopt_library
from .powell import PowellBackend
from .sqp import SqpBackend

__all__ = ["SOLVER_NAMES", "ALIASES", "FASTEST_SOLVER", "canonical_name", "same_iterates", "make_backend",
           "start_backend"]

SOLVER_NAMES = ("ipopt-cold", "ipopt-warm", "ipopt-warm-compiled", "sqpmethod-qrqp", "sqpmethod-daqp", "fatrop",
                "sqpmethod-daqp+fatrop", "powell")
ALIASES = {"ipopt": "ipopt-warm"}
FASTEST_SOLVER = "sqpmethod-daqp+fatrop"
"""The backend ``gpcnav bench`` chose on both presets (docs/solvers.md): the presets'
``PlannerConfig.solver`` and the label generator's default."""


def canonical_name(name: str) -> str:
    """The backend name behind ``name`` (aliases resolved); ValueError if unknown."""
    name = ALIASES.get(name, name)
    if name not in SOLVER_NAMES:
        raise ValueError(f"unknown solver {name!r} (choose from {', '.join(SOLVER_NAMES + tuple(ALIASES))})")
    return name


def same_iterates(a: str, b: str) -> bool:
    """Whether solvers ``a`` and ``b`` take the same steps from the same start: the same
    backend, or the same IPOPT on CasADi's functions and on the same functions compiled (the
    same iterates to the bit, docs/solvers.md, "Backup"). A failed solve of one is not worth
    solving again with the other."""
    def algorithm(name: str) -> str:
        name = canonical_name(name)
        return name[:-len("-compiled")] if name.endswith("-compiled") else name
    return algorithm(a) == algorithm(b)


def make_backend(name: str, problem: GPCProblem, max_wall_time_s: float | None = None,
                 compiled: bool = True, ipopt_options: dict | None = None) -> Backend:
    """The backend ``name`` for ``problem``, built now (compiling if needed and not cached).

    ``max_wall_time_s`` caps IPOPT's own wall time (the controller's time budget); the SQP
    and fatrop are capped by their iteration limits, Powell by its evaluation limit.
    ``compiled=False`` keeps CasADi's uncompiled functions everywhere; ``ipopt_options`` are
    added to the IPOPT backends' options."""
    name = canonical_name(name)
    if name.startswith("ipopt-"):
        return IpoptBackend(name, problem, warm=name != "ipopt-cold", compiled=compiled and name.endswith("-compiled"),
                            max_wall_time_s=max_wall_time_s, extra_options=ipopt_options)
    if name == "sqpmethod-daqp+fatrop":
        # fatrop's compile (where its library is not cached yet) in its own process while the
        # SQP's runs here: a fresh cache waits for the longer of the two, not their sum
        sqp = while_compiling(start_fatrop_library(problem) if compiled else None,
                              lambda: SqpBackend("sqpmethod-daqp", problem, "daqp", compiled))
        return HybridBackend(name, sqp, FatropBackend("fatrop", problem, compiled))
    if name.startswith("sqpmethod-"):
        return SqpBackend(name, problem, name.split("-", 1)[1], compiled)
    if name == "fatrop":
        return FatropBackend(name, problem, compiled)
    return PowellBackend(name, problem)


def start_backend(name: str, problem: GPCProblem, compiled: bool = True):
    """Begin what building ``name`` on ``problem`` can do beside other work: the C compile of
    IPOPT's functions (``ipopt-*-compiled``), in a process of its own. An object whose
    ``finish()`` waits for it (call it before :func:`make_backend` of the same), or None when
    there is nothing to begin."""
    name = canonical_name(name)
    if compiled and name.startswith("ipopt-") and name.endswith("-compiled"):
        return start_ipopt_library(problem)
    return None
