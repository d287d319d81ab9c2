"""IPOPT on the single-shooting NLP: cold (its default barrier start) or warm (primal and
multiplier warm start), optionally with compiled NLP functions."""
from __future__ import annotations

import casadi as ca

from ..problem.cost import GPCProblem
from .base import CasadiBackend
from .compiling import Compile, build_nlpsol, known_library, start_compile

__all__ = ["IpoptBackend", "start_ipopt_library"]

_IPOPT_OK = {"Solve_Succeeded", "Solved_To_Acceptable_Level"}
_IPOPT_BASE = {"ipopt.print_level": 0, "ipopt.sb": "yes", "ipopt.tol": 1e-9, "ipopt.max_iter": 200,
               "print_time": False}
_IPOPT_WARM = {"ipopt.warm_start_init_point": "yes", "ipopt.warm_start_bound_push": 1e-9,
               "ipopt.warm_start_mult_bound_push": 1e-9, "ipopt.mu_init": 1e-3}


class IpoptBackend(CasadiBackend):
    def __init__(self, name: str, problem: GPCProblem, warm: bool, compiled: bool, max_wall_time_s: float | None,
                 extra_options: dict | None = None):
        super().__init__(name, problem)
        self.uses_multipliers = warm
        opts = dict(_IPOPT_BASE, **(_IPOPT_WARM if warm else {}))
        if max_wall_time_s is not None:
            opts["ipopt.max_wall_time"] = float(max_wall_time_s)
        opts.update(extra_options or {})
        solver, self.compiled, note = build_nlpsol(name.replace("-", "_"), "ipopt", problem.nlp, opts, compiled,
                                                   _library_what(problem))
        self.notes.append(note)
        self._setup(solver)

    def _status(self):
        stats = self.solver.stats()
        status = str(stats.get("return_status", "unknown"))
        return status in _IPOPT_OK, status, int(stats.get("iter_count", -1))


def _library_what(problem: GPCProblem) -> tuple:
    """What IPOPT's generated code depends on (:func:`~casadi_gpc.solvers.compiling.known_library`):
    the NLP only, not the options, so a second backend of the same problem in this process
    loads the library the first found."""
    return ("ipopt", *problem.code_key)


def start_ipopt_library(problem: GPCProblem) -> Compile | None:
    """Begin compiling IPOPT's NLP functions for ``problem`` in a process of their own, beside
    other work (the planner's main solver compiling its own), so a fresh cache pays the
    longer of the two compiles rather than their sum; None when this process already has the
    library. Once ``finish()`` returns, an :class:`IpoptBackend` of the problem, compiled,
    loads it."""
    what = _library_what(problem)
    if known_library(what) is not None:
        return None
    solver = ca.nlpsol("ipopt_code", "ipopt", problem.nlp, dict(_IPOPT_BASE, **_IPOPT_WARM))
    return start_compile(solver, "ipopt", problem.nlp, background=True, what=what)
