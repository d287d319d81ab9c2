"""The GPC's NLP solvers: one interface, each built once per problem and warm-started.

Every backend answers ``solve(p, u0, lam_x, lam_g) -> SolveResult`` for the problem of
:func:`casadi_gpc.problem.cost.build_problem` (decision variables: the wheel-speed increments ``u``),
so the controller, the label generator and the benchmark never ask which one they hold.

==========================  ===============================================================
name                        what it is
==========================  ===============================================================
``ipopt-cold``              IPOPT with its default barrier start (mu_init 0.1), primal start
                            only, no multipliers.
``ipopt-warm``              IPOPT as the planner used it before the fast solvers existed:
                            primal and multiplier warm start (``warm_start_init_point``,
                            mu_init 1e-3). ``ipopt`` is an alias.
``ipopt-warm-compiled``     ``ipopt-warm`` with the NLP functions generated as C and compiled.
``sqpmethod-qrqp``          CasADi's SQP, exact Hessian shifted to positive definite (IPOPT's
                            inertia correction),
                            QPs by ``qrqp``, compiled NLP functions.
``sqpmethod-daqp``          the same SQP with the dense active-set QP solver ``daqp``.
``fatrop``                  the same problem in multiple-shooting form (states and increments
                            in stage order, the stage cost of :mod:`casadi_gpc.problem.cost`), solved by
                            fatrop's structure-exploiting interior point; compiled functions.
``powell``                  the paper's method: scipy's Powell on the same cost, increments
                            bounded, wheel speeds kept within their limit by projection.
==========================  ===============================================================

Rooms: ``base`` (the result, the interface, the CasADi call path), ``compiling`` (the
generated C code and its cache), ``sqp`` (the SQP loop and its convexified Hessian),
``fatrop`` (the multiple-shooting transcription), ``ipopt``, ``powell``, ``hybrid`` (warm
starts by one backend, cold starts by another) and ``registry`` (names and
:func:`make_backend`).

A solve is successful only when the solver itself reports success and every output is
finite; nothing else is accepted silently.
"""
from .base import Backend, SolveResult, constraint_violation_mps
from .compiling import CFLAGS, COMPILE_EVENTS, c_compiler, cache_dir, compiled_library
from .powell import project_increments
from .registry import (ALIASES, FASTEST_SOLVER, SOLVER_NAMES, canonical_name, make_backend, same_iterates,
                       start_backend)

__all__ = [
    "SOLVER_NAMES", "ALIASES", "FASTEST_SOLVER", "SolveResult", "Backend", "make_backend", "start_backend",
    "same_iterates", "canonical_name",
    "cache_dir", "c_compiler", "COMPILE_EVENTS", "project_increments", "constraint_violation_mps", "CFLAGS",
    "compiled_library",
]
