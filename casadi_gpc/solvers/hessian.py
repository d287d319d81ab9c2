"""The exact Hessian of the GPC cost in the increments, by the chain rule over the roll-out.

The cost is a sum of stage terms of the states the increments roll out to,
``J(u) = sum_i phi_i(z_i(u)) + lambda1 |u|^2`` with ``z_i = (x, y, heading, v_right,
v_left)`` after step i (:func:`casadi_gpc.problem.cost.rollout_states`, :func:`state_cost`). So

    d2J/du2 = sum_i  Jz_i^T B_i Jz_i  +  d2/du2 (sum_i g_i . z_i(u))  +  2 lambda1 I,

with ``B_i`` the 5x5 Hessian and ``g_i`` the gradient of ``phi_i`` at ``z_i`` (the obstacle
terms enter only through ``B_i`` and ``g_i``, each a function of one state), ``Jz_i`` the
roll-out's Jacobian, and the middle term the roll-out's own curvature weighted by ``g_i``
(held fixed while differentiating; the speeds are linear in ``u``, so only positions and
heading weigh). CasADi's ``hessian`` of the whole cost differentiates every obstacle term
through the whole roll-out instead: the same matrix, within rounding, from twice the
operations (``improved``, H = 12, six movers: 119k instructions against 49k here; the
compiled function 66 against 27-37 us). Only the lower triangle is computed; the upper is its
mirror.
"""
from __future__ import annotations

import casadi as ca

from ..problem.cost import GPCProblem, effort_cost, parameter_blocks, rollout_states, state_cost

__all__ = ["cost_hessian"]


def cost_hessian(problem: GPCProblem) -> ca.Function:
    """``hess(u, p)``: the exact Hessian of ``problem``'s cost in ``u`` (dense, symmetric)."""
    cfg, robot, layout = problem.config, problem.robot, problem.layout
    H = cfg.horizon
    u = ca.SX.sym("u", 2 * H)
    p = ca.SX.sym("p", layout.size)
    P = parameter_blocks(layout, p)
    z = ca.SX.sym("z", 5)
    states = [ca.vertcat(*s) for s in rollout_states(cfg, robot, P["x0"], u)]
    # the roll-out's curvature, weighted: d2/du2 of sum_i w_i . (x_i, y_i, heading_i)
    w = ca.SX.sym("w", 3 * H)
    weighted = sum(ca.dot(w[3 * i:3 * i + 3], s[:3]) for i, s in enumerate(states))
    curvature = ca.Function("curvature", [u, p, w], [ca.tril(ca.hessian(weighted, u)[0])])
    hess = ca.SX(2 * H, 2 * H)
    weights = []
    for i, s in enumerate(states):
        B, g = ca.hessian(sum(state_cost(cfg, P, i, *(z[k] for k in range(5)))), z)
        g_i, B_i = ca.Function(f"stage{i}", [z, p], [g, B])(s, p)
        J = ca.jacobian(s, u)
        hess += ca.tril(ca.mtimes([J.T, B_i, J]))
        weights.append(g_i[:3])
    hess += curvature(u, p, ca.vertcat(*weights))
    hess += ca.tril(ca.hessian(sum(effort_cost(cfg, u[2 * i], u[2 * i + 1]) for i in range(H)), u)[0])
    return ca.Function("cost_hessian", [u, p], [ca.densify(ca.tril2symm(hess))], ["u", "p"], ["hess"])
