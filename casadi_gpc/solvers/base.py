"""What every solver backend shares: the result of a solve, the backend interface and the
CasADi call path (through the solver's buffer, bounds written once), and the constraint check
of an answer."""
from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from ..buffered import BufferedFunction
from ..problem.cost import GPCProblem

__all__ = ["SolveResult", "Backend", "CasadiBackend", "all_finite", "constraint_violation_mps"]


@dataclass(frozen=True)
class SolveResult:
    """One solve of the NLP: the increments, the cost and what the solver said."""

    u: np.ndarray
    cost: float
    success: bool
    status: str
    iterations: int
    lam_x: np.ndarray | None = None
    lam_g: np.ndarray | None = None
    solve_time_s: float = 0.0
    """Wall time of the whole call from Python (conversions included)."""
    evaluations: int = 0
    """Cost evaluations (Powell only; the gradient-based solvers count iterations)."""


def all_finite(*arrays) -> bool:
    """Whether every array given (None counts as finite) holds finite numbers only (a loop,
    not ``all()`` over a generator of ``np.all``: called twice a solve, it cost 10 us)."""
    isfinite = np.isfinite
    for a in arrays:
        if a is not None and not isfinite(a).all():
            return False
    return True


@dataclass
class Backend:
    """Base of the solver backends (built once for one :class:`GPCProblem`)."""

    name: str
    problem: GPCProblem
    compiled: bool = False
    notes: list = field(default_factory=list)

    def solve(self, p, u0, lam_x=None, lam_g=None) -> SolveResult:
        """Solve at parameters ``p`` from ``u0`` (and the multipliers, where used).

        Non-finite inputs are refused before the solver sees them (fatrop, given a NaN,
        does not return)."""
        if not all_finite(np.asarray(p, float), np.asarray(u0, float), lam_x, lam_g):
            return self._failed(u0, "refused: non-finite parameters or start", time.perf_counter())
        return self._solve(np.asarray(p, float), np.asarray(u0, float), lam_x, lam_g)

    def _solve(self, p, u0, lam_x, lam_g) -> SolveResult:  # pragma: no cover - interface
        raise NotImplementedError

    def fork(self) -> "Backend | None":
        """A twin that may solve in another thread at the same time as this one (the same
        compiled functions, its own memory and arrays: :mod:`casadi_gpc.planner.lanes`), or None
        where that is not safe: IPOPT (known to crash under threads), anything that calls
        back into Python (Powell, the uncompiled SQP's Hessian)."""
        return None

    def _twin(self):
        """A shallow copy with its own buffer of the solver (``self.solver``, a
        :class:`~casadi_gpc.buffered.BufferedFunction`): what :meth:`fork` returns where it is
        safe."""
        twin = copy.copy(self)
        twin.notes = list(self.notes)
        twin.solver = self.solver.fork()
        return twin

    def info(self) -> dict:
        return {"name": self.name, "compiled": self.compiled, "notes": list(self.notes)}

    def _failed(self, u0, status: str, t0: float) -> SolveResult:
        return SolveResult(np.asarray(u0, float), float("nan"), False, status, -1, None, None,
                           time.perf_counter() - t0)


class CasadiBackend(Backend):
    """Shared call path: the solver called through its buffer (:mod:`casadi_gpc.buffered`),
    the constant bounds written once."""

    uses_multipliers = True

    def _setup(self, solver: ca.Function):
        pr = self.problem
        # inputs x0, p, lbx, ubx, lbg, ubg, lam_x0, lam_g0; outputs x, f, g, lam_x, lam_g, lam_p
        self.solver = BufferedFunction(solver)
        for i, bound in enumerate((pr.lbx, pr.ubx, pr.lbg, pr.ubg), start=2):
            self.solver.inputs[i][:] = bound

    def _status(self) -> tuple[bool, str, int]:
        stats = self.solver.stats()
        return bool(stats.get("success", False)), str(stats.get("return_status", "unknown")), int(
            stats.get("iter_count", -1))

    def _solve(self, p, u0, lam_x, lam_g) -> SolveResult:
        t0 = time.perf_counter()
        warm = self.uses_multipliers and lam_x is not None and lam_g is not None
        try:
            ret = self.solver(u0, p, None, None, None, None, lam_x if warm else 0.0, lam_g if warm else 0.0)
            ok, status, iters = self._status()
        except RuntimeError as exc:  # evaluation errors, or no status after a failed QP
            return self._failed(u0, f"error: {str(exc).strip().splitlines()[-1]}", t0)
        return self._result(ret, ok, status, iters, t0)

    def _result(self, ret: int, ok: bool, status: str, iters: int, t0: float, scale: float = 1.0) -> SolveResult:
        """The solution in the solver's outputs (the objective and multipliers divided by
        ``scale``, the objective's scale): a copy, since the next call overwrites them."""
        out = self.solver.outputs
        u, cost = out[0].copy(), float(out[1][0]) / scale
        lx, lg = out[3] / scale, out[4] / scale  # multipliers of the unscaled problem (new arrays)
        if ret:
            ok, status = False, f"error: the solver returned {ret} ({status})"
        ok = ok and math.isfinite(cost) and all_finite(u, lx, lg)
        return SolveResult(u, cost, ok, status, iters, lx, lg, time.perf_counter() - t0)


def constraint_violation_mps(problem: GPCProblem, u: np.ndarray, p: np.ndarray) -> float:
    """Largest violation (m/s) of the increment bounds and the wheel-speed limits by ``u``."""
    u = np.asarray(u, float)
    v = np.asarray(p[3:5], float) + np.cumsum(u.reshape(-1, 2), axis=0)
    over_u = np.max(np.maximum(u - problem.ubx, problem.lbx - u), initial=0.0)
    over_v = np.max(np.maximum(v.reshape(-1) - problem.ubg, problem.lbg - v.reshape(-1)), initial=0.0)
    return float(max(over_u, over_v, 0.0))
