"""The paper's method: scipy's Powell on the same cost, increments bounded, wheel speeds
kept within their limit by projection."""
from __future__ import annotations

import math
import time

import casadi as ca
import numpy as np

from ..problem.cost import GPCProblem
from .base import Backend, SolveResult, all_finite

__all__ = ["PowellBackend", "project_increments"]


def project_increments(u: np.ndarray, v0: np.ndarray, dv_max: float, v_max: float) -> np.ndarray:
    """Increments clipped step by step so each wheel's speed stays within ``+-v_max``
    (and each increment within ``+-dv_max``), starting from the wheel speeds ``v0``."""
    steps = np.clip(np.asarray(u, float).reshape(-1, 2), -dv_max, dv_max)
    v = np.array(v0, dtype=float)
    out = np.empty_like(steps)
    for i, s in enumerate(steps):
        nxt = np.clip(v + s, -v_max, v_max)
        out[i] = nxt - v
        v = nxt
    return out.reshape(-1)


class PowellBackend(Backend):
    """The paper's method: scipy's Powell on the same cost, warm-started.

    Powell has no general constraints. Its bounds keep each increment within the
    acceleration limit; the wheel-speed limit is kept by evaluating the cost at
    :func:`project_increments` of the point, and the projected point is the answer, so the
    answer is always feasible (the benchmark still measures its violation).
    """

    def __init__(self, name: str, problem: GPCProblem, xtol: float = 1e-6, ftol: float = 1e-10,
                 maxfev: int = 50000):
        super().__init__(name, problem)
        self.options = {"xtol": xtol, "ftol": ftol, "maxfev": maxfev}
        self.notes.append(f"scipy Powell, bounds on increments, projection onto the wheel-speed limits, "
                          f"xtol {xtol:g}, ftol {ftol:g}, maxfev {maxfev}")
        robot, T = problem.robot, problem.config.sample_time_s
        self._dv, self._vmax = robot.max_step_change_mps(T), robot.max_wheel_speed_mps

    def _solve(self, p, u0, lam_x, lam_g) -> SolveResult:
        from scipy.optimize import minimize
        t0 = time.perf_counter()
        pr, v0 = self.problem, np.asarray(p[3:5], float)
        pdm = ca.DM(p)

        def cost(u):
            return float(pr.cost_fn(project_increments(u, v0, self._dv, self._vmax), pdm))

        start = project_increments(u0, v0, self._dv, self._vmax)
        try:
            res = minimize(cost, start, method="Powell", bounds=list(zip(pr.lbx, pr.ubx)), options=self.options)
        except (RuntimeError, ValueError) as exc:
            return self._failed(u0, f"error: {exc}", t0)
        u = project_increments(res.x, v0, self._dv, self._vmax)
        f = float(res.fun)
        ok = bool(res.success) and math.isfinite(f) and all_finite(u)
        return SolveResult(u, f, ok, str(res.message), int(res.nit), None, None, time.perf_counter() - t0,
                           int(res.nfev))
