"""CasADi's SQP on the single-shooting NLP: the exact Hessian of the Lagrangian made
positive definite by an IPOPT-style inertia correction (compiled into the Hessian function,
or a numpy callback without a compiler), the objective scaled as IPOPT's gradient-based
scaling, QPs by ``qrqp`` or ``daqp``."""
from __future__ import annotations

import math
import time
import warnings
from pathlib import Path

import casadi as ca
import numpy as np

from ..problem.cost import GPCProblem
from ..buffered import BufferedFunction
from .base import CasadiBackend, SolveResult
from .compiling import COMPILE_EVENTS, compiled_library, known_library, remember_library
from .hessian import cost_hessian

__all__ = ["SqpBackend", "ConvexifiedHessian", "CONVEXIFY_C", "SCALE_MAX_GRADIENT", "lagrangian_hessian",
           "convexified_hessian_source"]

_SQP = {
    # The exact Hessian, made positive definite by :data:`CONVEXIFY_C` (passed as hess_lag),
    # not by casadi's convexify_strategy: its eigen-clip / eigen-reflect fail on about a
    # third of random symmetric 24 x 24 matrices with a wide eigenvalue spread, and on some
    # of this problem's Hessians near obstacles (reported failures, but failures), and its
    # "regularize" (a Gershgorin shift) is so large that the SQP needs 100+ iterations.
    "hessian_approximation": "exact",
    "max_iter": 100,
    # Stationarity to 1e-6 in a cost whose Hessian is >= 2 lambda1 = 126 puts u within ~1e-8
    # of the optimum and the cost within ~1e-14 relative: far inside the 1e-6 the
    # benchmark asks; tighter, the SQP sometimes stalls on the kinks of the improved cost.
    "tol_pr": 1e-6,
    "tol_du": 1e-6,
    "min_step_size": 1e-14,
    # The default of 3 backtracking steps lets a rejected step through; the iterates then
    # wander into another basin. 30 keeps the line search honest.
    "max_iter_ls": 30,
    "print_header": False, "print_iteration": False, "print_status": False, "print_time": False,
    "error_on_fail": False,
}
_QPSOL_OPTIONS = {
    "qrqp": {"print_iter": False, "print_header": False, "print_info": False, "error_on_fail": False},
    "daqp": {"error_on_fail": False},
}


CONVEXIFY_C = r"""
#include <math.h>
/* gpcnav: the exact Hessian H (dense, column-major, n x n) is replaced by H + delta I with
   the first delta of 0, 1e-8 s, 4e-8 s, 1.6e-7 s, ... (s = max(1, max |H_ii|)) for which
   a Cholesky factorisation succeeds with pivots above 1e-10 s: IPOPT's inertia correction.
   Returns 1 (the solve fails, reported) if none does, e.g. when H holds a NaN. */
static int gpc_cholesky_ok(const casadi_real* H, casadi_int n, casadi_real delta, casadi_real tiny,
                           casadi_real* L) {
  casadi_int i, j, k;
  casadi_real d, t;
  for (j = 0; j < n; ++j) {
    d = H[j + j * n] + delta;
    for (k = 0; k < j; ++k) d -= L[j + k * n] * L[j + k * n];
    if (!(d > tiny)) return 0;
    d = sqrt(d);
    L[j + j * n] = d;
    for (i = j + 1; i < n; ++i) {
      t = H[i + j * n];
      for (k = 0; k < j; ++k) t -= L[i + k * n] * L[j + k * n];
      L[i + j * n] = t / d;
    }
  }
  return 1;
}

static int gpc_convexify(casadi_real* H) {
  casadi_real L[GPC_N * GPC_N], s = 1, delta = 0, a;
  casadi_int i, tries;
  if (!H) return 0;
  for (i = 0; i < GPC_N; ++i) {
    a = fabs(H[i + i * GPC_N]);
    if (a > s) s = a;
  }
  for (tries = 0; tries < 100; ++tries) {
    if (gpc_cholesky_ok(H, GPC_N, delta, 1e-10 * s, L)) {
      for (i = 0; i < GPC_N; ++i) H[i + i * GPC_N] += delta;
      return 0;
    }
    delta = delta == 0 ? 1e-8 * s : 4 * delta;
  }
  return 1;
}
"""
"""The C convexification compiled into the SQP's Hessian function (``GPC_N`` = n_u)."""

_NOTE = "Hessian: exact + delta I (IPOPT-style inertia correction); objective scaled as IPOPT's gradient-based scaling"
_HESS_NAME = "gpc_hess_cvx"
_HESS_CALL = "  return casadi_f0(arg, res, iw, w, mem);"


def lagrangian_hessian(problem: GPCProblem, scaled: dict) -> ca.Function:
    """The exact, dense Hessian of the Lagrangian of ``scaled`` (``problem``'s NLP, its
    objective times the scale appended to the parameters), with sqpmethod's ``hess_lag``
    signature: ``lam_f`` times the scale times the cost's Hessian by the chain rule
    (:func:`casadi_gpc.solvers.hessian.cost_hessian`, half the operations of CasADi's
    ``hessian`` of the whole cost). The constraints (the wheel speeds) are linear in the
    increments, so the multipliers do not enter; checked here."""
    x, p_ext, g = scaled["x"], scaled["p"], scaled["g"]
    lam_f, lam_g = ca.SX.sym("lam_f"), ca.SX.sym("lam_g", g.numel())
    if ca.hessian(ca.dot(lam_g, g), x)[0].nnz():
        raise ValueError("the SQP's Hessian assumes constraints linear in the increments")
    n_p = problem.layout.size
    hess = lam_f * p_ext[n_p] * cost_hessian(problem)(x, p_ext[:n_p])
    return ca.Function(_HESS_NAME, [x, p_ext, lam_f, lam_g], [hess], ["x", "p", "lam_f", "lam_g"], ["hess"])


def convexified_hessian_source(hess: ca.Function, *others: ca.Function) -> str:
    """C source of ``hess`` followed by :data:`CONVEXIFY_C`, applied to its output (and of
    ``others``, unchanged)."""
    cg = ca.CodeGenerator(f"{_HESS_NAME}.c", {"with_header": False})
    cg.add(hess)
    for fn in others:
        cg.add(fn)
    code = cg.dump()
    head = f"CASADI_SYMBOL_EXPORT int {_HESS_NAME}(const casadi_real** arg, casadi_real** res, casadi_int* iw, "
    at = code.find(head)
    call = code.find(_HESS_CALL, at)
    if at < 0 or call < 0 or code.count(_HESS_CALL) != 1:  # the generated code changed shape: do not guess
        raise RuntimeError("unexpected layout of the generated Hessian code")
    n = hess.size1_out(0)
    return (code[:at] + f"#define GPC_N {n}\n" + CONVEXIFY_C + code[at:call]
            + "  if (casadi_f0(arg, res, iw, w, mem)) return 1;\n  return gpc_convexify(res[0]);"
            + code[call + len(_HESS_CALL):])


class ConvexifiedHessian(ca.Callback):
    """The same convexification as :data:`CONVEXIFY_C`, in numpy, for when nothing is
    compiled (slower: one Python call per SQP iteration)."""

    def __init__(self, hess: ca.Function):
        ca.Callback.__init__(self)
        self.hess = hess
        self.construct(_HESS_NAME, {})

    def get_n_in(self):
        return 4

    def get_n_out(self):
        return 1

    def get_name_in(self, i):
        return self.hess.name_in(i)

    def get_name_out(self, i):
        return "hess"

    def get_sparsity_in(self, i):
        return self.hess.sparsity_in(i)

    def get_sparsity_out(self, i):
        return self.hess.sparsity_out(0)

    def eval(self, arg):
        h = np.array(self.hess(*arg), dtype=float)
        s = max(1.0, float(np.max(np.abs(np.diag(h))))) if np.all(np.isfinite(np.diag(h))) else 1.0
        delta, n = 0.0, h.shape[0]
        for _ in range(100):
            try:
                low = np.linalg.cholesky(h + delta * np.eye(n))
                if np.all(np.diag(low) ** 2 > 1e-10 * s):
                    return [h + delta * np.eye(n)]
            except np.linalg.LinAlgError:
                pass
            delta = 1e-8 * s if delta == 0 else 4 * delta
        raise RuntimeError("Hessian not convexifiable")


_GRAD_NAME = "gpc_grad_inf"
SCALE_MAX_GRADIENT = 100.0
"""The SQP minimises ``s J`` with ``s = min(1, 100 / |grad J(u0)|_inf)``: IPOPT's
gradient-based scaling (its ``nlp_scaling_max_gradient``). Its stopping tolerances are
absolute; without this, a start far inside an obstacle's penalty (J ~ 1e6, gradients
~1e8) reaches IPOPT's cost to 1e-8 relative but never its 1e-6 stationarity, and fails."""


class SqpBackend(CasadiBackend):
    # The constraints are linear in u, so the multipliers do not enter the Lagrangian's
    # Hessian; measured: passing them changes no iteration count and costs a conversion.
    uses_multipliers = False

    def __init__(self, name: str, problem: GPCProblem, qpsol: str, compiled: bool):
        super().__init__(name, problem)
        tag = name.replace("-", "_")
        opts = dict(_SQP, qpsol=qpsol, qpsol_options=_QPSOL_OPTIONS[qpsol])
        nlp = problem.nlp
        scale = ca.SX.sym("scale")  # the objective's scale, appended to the parameters
        p_ext = ca.vertcat(nlp["p"], scale)
        scaled = {"x": nlp["x"], "p": p_ext, "f": scale * nlp["f"], "g": nlp["g"]}
        what = ("sqpmethod", name, qpsol, *problem.code_key)  # all the generated code depends on
        known = known_library(what) if compiled else None
        if known is not None:  # this process built it before: no symbolic NLP, no code to hash
            self._from_library(tag, opts, known)
            return
        hess = lagrangian_hessian(problem, scaled)
        grad_inf = ca.Function(_GRAD_NAME, [nlp["x"], p_ext], [ca.norm_inf(ca.gradient(nlp["f"], nlp["x"]))])
        solver, note = None, "uncompiled CasADi functions"
        if compiled:
            plain = ca.nlpsol(tag, "sqpmethod", scaled, opts)  # its fg and jac_fg are compiled
            try:
                extra = {f"{_HESS_NAME}.c": convexified_hessian_source(hess, grad_inf)}
                lib, note = compiled_library(plain, "sqpmethod", scaled, extra)
            except RuntimeError as exc:
                lib, note = None, f"no compiled Hessian: {exc}"
            if lib is None:
                COMPILE_EVENTS["fallbacks"] += 1
                warnings.warn(f"solver {name}: {note}", RuntimeWarning, stacklevel=3)
            else:
                remember_library(what, lib)
                self._from_library(tag, opts, lib, note)
                return
        if solver is None:
            self._hessian = ConvexifiedHessian(hess)  # a Callback must outlive the solver
            solver = ca.nlpsol(tag, "sqpmethod", scaled, dict(opts, hess_lag=self._hessian))
        self._setup(solver)
        self._bind_gradient(grad_inf)
        self.notes.append(note + "; " + _NOTE)

    def _from_library(self, tag: str, opts: dict, lib: str, note: str | None = None) -> None:
        """The solver of the compiled library ``lib`` (its functions, the convexified Hessian
        and the gradient's norm)."""
        solver = ca.nlpsol(tag, "sqpmethod", lib, dict(opts, hess_lag=ca.external(_HESS_NAME, lib)))
        self.compiled = True
        self._setup(solver)
        self._bind_gradient(ca.external(_GRAD_NAME, lib))
        note = note or f"compiled functions (cached {Path(lib).name})"
        self.notes.append(note + "; " + _NOTE)

    def fork(self) -> "SqpBackend | None":
        if not self.compiled:  # the numpy Hessian is a Python callback inside the solver
            return None
        twin = self._twin()
        twin._bind_gradient(self._grad_inf.fn)
        return twin

    def _bind_gradient(self, grad_inf: ca.Function) -> None:
        """|grad J(u0)|_inf, reading the solver's own start and parameters (the scale is the
        parameters' last entry)."""
        self._grad_inf = BufferedFunction(grad_inf, share={0: self.solver.inputs[0], 1: self.solver.inputs[1]})

    def _solve(self, p, u0, lam_x, lam_g) -> SolveResult:
        t0 = time.perf_counter()
        x0, p_ext = self.solver.inputs[0], self.solver.inputs[1]
        x0[:] = u0
        p_ext[:-1] = p
        p_ext[-1] = 1.0
        try:
            self._grad_inf()
            g = float(self._grad_inf.outputs[0][0])
            scale = min(1.0, SCALE_MAX_GRADIENT / g) if g > 0 and math.isfinite(g) else 1.0
            p_ext[-1] = scale
            ret = self.solver()
            ok, status, iters = self._status()
        except RuntimeError as exc:  # evaluation errors, or no status after a failed QP
            return self._failed(u0, f"error: {str(exc).strip().splitlines()[-1]}", t0)
        return self._result(ret, ok, status, iters, t0, scale)

    def _status(self):
        # return_status can be stale after a failed QP (casadi 3.8); success is not.
        stats = self.solver.stats()
        ok = bool(stats.get("success", False))
        status = str(stats.get("return_status", "unknown")) if ok else str(
            stats.get("unified_return_status", stats.get("return_status", "unknown")))
        return ok, status, int(stats.get("iter_count", -1))

