"""The multiple-shooting transcription of the GPC problem, solved by fatrop."""
from __future__ import annotations

import math
import time

import casadi as ca
import numpy as np

from ..problem.cost import GPCProblem, effort_cost, parameter_blocks, state_cost
from ..robot import robot_step, robot_step_float
from ..buffered import BufferedFunction
from .base import Backend, SolveResult, all_finite
from .compiling import Compile, build_nlpsol, known_library, start_compile

__all__ = ["FatropBackend", "start_fatrop_library"]

# mu_init 1e-3 left one H=12 warm start at max_iter. tol 1e-6, the SQP's own: at 1e-9, 27 of 685
# cold starts among the UCY recordings failed for want of precision (none at 1e-6) and went on to
# the IPOPT backup, 36 ms each, the worst decisions there (docs/pedestrians.md)
_FATROP = {"print_level": 0, "tol": 1e-6, "mu_init": 1e-2, "max_iter": 200}


def _stagewise(problem: GPCProblem):
    """fatrop's NLP of ``problem`` (a function that builds it: a known library skips it), its
    options, and the bounds of its variables (:class:`FatropBackend`)."""
    cfg, robot = problem.config, problem.robot
    H, T = cfg.horizon, cfg.sample_time_s
    vmax, dv = robot.max_wheel_speed_mps, robot.max_step_change_mps(T)
    lbw, ubw = [], []
    for k in range(H + 1):
        lim = np.inf if k == 0 else vmax  # X_0 is fixed by its equality constraint
        lbw += [-np.inf] * 3 + [-lim] * 2
        ubw += [np.inf] * 3 + [lim] * 2
        if k < H:
            lbw += [-dv] * 2
            ubw += [dv] * 2
    n_g = 5 * (H + 1)  # X_0 = x0, then one state a stage

    def stagewise_nlp() -> dict:
        p = ca.SX.sym("p", problem.layout.size)
        P = parameter_blocks(problem.layout, p)
        X = [ca.SX.sym(f"x{k}", 5) for k in range(H + 1)]
        U = [ca.SX.sym(f"u{k}", 2) for k in range(H)]
        w, g, J = [], [X[0] - P["x0"]], 0
        for k in range(H + 1):
            w.append(X[k])
            if k > 0:
                J += sum(state_cost(cfg, P, k - 1, *(X[k][i] for i in range(5))))
            if k < H:
                w.append(U[k])
                J += effort_cost(cfg, U[k][0], U[k][1])
                vr, vl = X[k][3] + U[k][0], X[k][4] + U[k][1]
                xn, yn, thn = robot_step(ca, X[k][0], X[k][1], X[k][2], vr, vl, T, robot.wheel_base_m)
                g.append(X[k + 1] - ca.vertcat(xn, yn, thn, vr, vl))
        G = ca.vertcat(*g)
        if G.numel() != n_g:  # the options below are made before the NLP (a known library skips it)
            raise AssertionError(f"fatrop NLP has {G.numel()} equality constraints, its options {n_g}")
        return {"x": ca.vertcat(*w), "p": p, "f": J, "g": G}

    opts = {"structure_detection": "auto", "equality": [True] * n_g, "print_time": False,
            "fatrop": dict(_FATROP)}
    return stagewise_nlp, opts, lbw, ubw


def _library_what(name: str, problem: GPCProblem) -> tuple:
    """What fatrop's generated code depends on (:func:`~casadi_gpc.solvers.compiling.known_library`)."""
    return ("fatrop", name, *problem.code_key)


def start_fatrop_library(problem: GPCProblem, name: str = "fatrop") -> Compile | None:
    """Begin compiling fatrop's NLP functions for ``problem`` in a process of their own, beside
    other work (the SQP's compile, in the planner's hybrid solver): None when this process
    already has the library. Once ``finish()`` returns, a compiled :class:`FatropBackend`
    named ``name`` of the problem loads it."""
    what = _library_what(name, problem)
    if known_library(what) is not None:
        return None
    build, opts, _, _ = _stagewise(problem)
    nlp = build()
    return start_compile(ca.nlpsol(name, "fatrop", nlp, opts), "fatrop", nlp, background=True, what=what)


class FatropBackend(Backend):
    """The same problem in multiple shooting, stage by stage, for fatrop.

    Variables ``[X_0, U_0, X_1, U_1, ..., X_H]`` with ``X = (x, y, heading, v_right, v_left)``
    and ``U`` the increments; constraints ``X_0 = x0`` and ``X_{k+1} = F(X_k, U_k)`` with
    :func:`robot_step`; the cost is :func:`effort_cost` of ``U_k`` plus :func:`state_cost` of
    ``X_{k+1}``, the very terms the single-shooting NLP sums, so both share one optimum.
    Warm start: the states of the rolled-out ``u0``; fatrop takes no multiplier warm start.
    """

    def __init__(self, name: str, problem: GPCProblem, compiled: bool):
        super().__init__(name, problem)
        H = problem.config.horizon
        stagewise_nlp, opts, lbw, ubw = _stagewise(problem)
        if not compiled:
            opts["expand"] = True
        solver, self.compiled, note = build_nlpsol(name, "fatrop", stagewise_nlp, opts, compiled,
                                                   _library_what(name, problem))
        self.notes.append(note)
        # inputs w0, p, lbw, ubw, lbg, ubg (zeros: equalities), lam_x0, lam_g0 (zeros: fatrop takes none)
        self.solver = BufferedFunction(solver)
        self.solver.inputs[2][:] = lbw
        self.solver.inputs[3][:] = ubw
        self._iu = np.concatenate([np.arange(7 * k + 5, 7 * k + 7) for k in range(H)])
        self._iv = np.concatenate([np.arange(7 * k + 3, 7 * k + 5) for k in range(1, H + 1)])
        self._ix = np.concatenate([np.arange(7 * k, 7 * k + 5) for k in range(1, H + 1)])

    def fork(self) -> "FatropBackend":
        """A twin with its own buffer, so its own fatrop memory: one fatrop solver is not
        thread-safe, two memories of it solved in two threads gave the same numbers as one
        after the other (``tests/test_lanes.py``)."""
        return self._twin()

    def _states(self, x0, u0) -> list[float]:
        """The states X_1..X_H (x, y, heading, v_right, v_left) of the increments ``u0`` rolled
        out from ``x0`` with the robot model (plain floats: 12 steps cost less than one
        call of the CasADi roll-out with its conversions)."""
        cfg = self.problem.config
        T, W = cfg.sample_time_s, self.problem.robot.wheel_base_m
        x, y, th, vr, vl = (float(a) for a in x0)
        out = []
        u = np.asarray(u0, dtype=float).tolist()
        for k in range(cfg.horizon):
            vr, vl = vr + u[2 * k], vl + u[2 * k + 1]
            x, y, th = robot_step_float(x, y, th, vr, vl, T, W)
            out += (x, y, th, vr, vl)
        return out

    def _solve(self, p, u0, lam_x, lam_g) -> SolveResult:
        t0 = time.perf_counter()
        w0 = self.solver.inputs[0]
        w0[:5] = p[:5]
        w0[self._ix] = self._states(p[:5], u0)
        w0[self._iu] = u0
        try:
            ret = self.solver(None, p)
            stats = self.solver.stats()
        except RuntimeError as exc:
            return self._failed(u0, f"error: {str(exc).strip().splitlines()[-1]}", t0)
        out = self.solver.outputs
        w, lam_w = out[0], out[3]
        u, cost = w[self._iu], float(out[1][0])  # fancy indexing: copies
        # the single-shooting multipliers: increment bounds and wheel-speed limits
        lx, lg = lam_w[self._iu], lam_w[self._iv]
        ok = bool(stats.get("success", False)) and not ret and math.isfinite(cost) and all_finite(w, lam_w)
        status = str(stats.get("return_status", "unknown"))
        if ret:
            status = f"error: the solver returned {ret} ({status})"
        return SolveResult(u, cost, ok, status, int(stats.get("iter_count", -1)), lx, lg, time.perf_counter() - t0)
