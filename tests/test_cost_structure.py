"""The planner's problem by its structure: the cost's Hessian by the chain rule over the
roll-out (against CasADi's own Hessian of the whole cost), the parameter vector packed from
its empty template (against the definition of each block), and the obstacle forecast
traced into a CasADi function (against the float form, bit for bit)."""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from casadi_gpc.config import PRESETS
from casadi_gpc.problem.cost import FAR_AWAY_M, ParameterLayout, build_problem
from casadi_gpc.estimation.ekf_floats import propagate
from casadi_gpc.estimation.forecast_function import ForecastFunction
from casadi_gpc.solvers.hessian import cost_hessian
from casadi_gpc.solvers.sqp import lagrangian_hessian
from casadi_gpc.types import ObstacleForecast, StaticObstacle


def _random_parameters(layout: ParameterLayout, rng, n_moving: int, n_static: int, near: bool) -> np.ndarray:
    """A tick's parameters: the robot at the origin, a reference ahead, movers and statics
    around it (``near``: within a metre of the robot's path, where the penalties are stiff)."""
    H = layout.horizon
    x0 = np.array([0.0, 0.0, rng.uniform(-0.3, 0.3), rng.uniform(0.1, 0.5), rng.uniform(0.1, 0.5)])
    ref = np.column_stack([np.linspace(0.3, 3.0, H), rng.normal(0.0, 0.2, H), np.zeros(H)])
    spread = 1.0 if near else 4.0
    forecasts = []
    for j in range(n_moving):
        start = np.array([rng.uniform(0.5, 3.0), rng.normal(0.0, spread)])
        means = start + np.outer(np.arange(1, H + 1), rng.normal(0.0, 0.1, 2))
        A = rng.normal(0.0, 0.1, (H, 2, 2))
        forecasts.append(ObstacleForecast(j, rng.uniform(0.2, 0.4), means, A @ A.transpose(0, 2, 1) + 1e-3 * np.eye(2)))
    statics = [StaticObstacle((rng.uniform(0.5, 3.0), rng.normal(0.0, spread)), rng.uniform(0.2, 0.5))
               for _ in range(n_static)]
    return layout.pack(x0, ref, forecasts, statics, 0.5, None)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_the_chain_rule_hessian_is_casadis_hessian_of_the_whole_cost(name):
    """The SQP's Hessian (``cost_hessian``: stage Hessians through the roll-out's Jacobian,
    plus the roll-out's curvature weighted by the stage gradients) equals CasADi's
    ``hessian`` of the whole cost, to rounding, at random increments among random obstacles,
    near ones included; it is symmetric, and has fewer operations."""
    problem = build_problem(PRESETS[name])
    nlp = problem.nlp
    reference = ca.Function("h", [nlp["x"], nlp["p"]], [ca.densify(ca.hessian(nlp["f"], nlp["x"])[0])])
    chained = cost_hessian(problem)
    assert chained.n_instructions() < 0.7 * reference.n_instructions()
    layout, rng = problem.layout, np.random.default_rng(3)
    dv = problem.ubx[0]
    for trial in range(40):
        p = _random_parameters(layout, rng, int(rng.integers(0, layout.max_moving + 1)),
                               int(rng.integers(0, layout.max_static + 1)), near=trial % 2 == 0)
        u = rng.uniform(-dv, dv, problem.n_u)
        a, b = np.array(reference(u, p)), np.array(chained(u, p))
        assert np.all(np.isfinite(a))
        np.testing.assert_allclose(b, a, rtol=0, atol=1e-10 * max(1.0, np.abs(a).max()))
        assert np.array_equal(b, b.T)


def test_the_sqp_hessian_scales_the_cost_hessian_and_refuses_nonlinear_constraints():
    """hess_lag(x, [p, s], lam_f, lam_g) = lam_f s H(x, p); a constraint that is not linear
    in the increments would need its multipliers' curvature, which this Hessian leaves out:
    refused."""
    problem = build_problem(PRESETS["paper"])
    nlp = problem.nlp
    scale = ca.SX.sym("scale")
    scaled = {"x": nlp["x"], "p": ca.vertcat(nlp["p"], scale), "f": scale * nlp["f"], "g": nlp["g"]}
    hess = lagrangian_hessian(problem, scaled)
    rng = np.random.default_rng(0)
    p = _random_parameters(problem.layout, rng, 1, 1, near=True)
    u = rng.uniform(-0.1, 0.1, problem.n_u)
    plain = np.array(cost_hessian(problem)(u, p))
    np.testing.assert_allclose(np.array(hess(u, np.r_[p, 0.25], 2.0, np.ones(problem.n_u))), 0.5 * plain,
                               rtol=1e-15, atol=0)
    bent = dict(scaled, g=ca.vertcat(nlp["g"], nlp["x"][0] ** 2))
    with pytest.raises(ValueError, match="linear"):
        lagrangian_hessian(problem, bent)


def test_pack_fills_each_block_by_its_definition_and_leaves_the_template_alone():
    """Each block of the packed vector as documented (ParameterLayout.blocks): the movers'
    means, P = 1 + trace / scale^2, the worst-direction sigma, radii and flags in the first
    slots, the rest parked far away; a pack with fewer obstacles after one with more shows
    no trace of the first."""
    layout = ParameterLayout(5, 3, 2)
    rng = np.random.default_rng(1)
    forecasts = []
    for j in range(2):
        A = rng.normal(size=(5, 2, 2))
        forecasts.append(ObstacleForecast(j, 0.3 + j, rng.normal(size=(5, 2)), A @ A.transpose(0, 2, 1)))
    statics = [StaticObstacle((1.0, -2.0), 0.4)]
    x0, ref = rng.normal(size=5), rng.normal(size=(5, 3))
    full = layout.unpack(layout.pack(x0, ref, forecasts, statics, 0.5, np.arange(5.0)))
    np.testing.assert_array_equal(full["x0"], x0)
    np.testing.assert_array_equal(full["ref"], ref)
    np.testing.assert_array_equal(full["ref_w"], np.arange(5.0))
    for j, f in enumerate(forecasts):
        np.testing.assert_array_equal(full["mov_xy"][j], f.means_m)
        np.testing.assert_allclose(full["mov_p"][j], 1 + np.trace(f.covs_m2, axis1=1, axis2=2) / 0.25, rtol=1e-15)
        np.testing.assert_allclose(full["mov_sigma"][j], np.sqrt(np.linalg.eigvalsh(f.covs_m2)[:, -1]), rtol=1e-12)
    np.testing.assert_array_equal(full["mov_r"], [0.3, 1.3, 0.0])
    np.testing.assert_array_equal(full["mov_on"], [1.0, 1.0, 0.0])
    np.testing.assert_array_equal(full["mov_xy"][2], FAR_AWAY_M)
    np.testing.assert_array_equal(full["mov_p"][2], 1.0)
    np.testing.assert_array_equal(full["sta_xy"], [[1.0, -2.0], [FAR_AWAY_M, FAR_AWAY_M]])
    np.testing.assert_array_equal(full["sta_r"], [0.4, 0.0])
    np.testing.assert_array_equal(full["sta_on"], [1.0, 0.0])
    empty = layout.unpack(layout.pack(x0, ref))
    np.testing.assert_array_equal(empty["mov_xy"], FAR_AWAY_M)
    np.testing.assert_array_equal(empty["sta_xy"], FAR_AWAY_M)
    np.testing.assert_array_equal(empty["ref_w"], 1.0)
    for name in ("mov_sigma", "mov_r", "mov_on", "sta_r", "sta_on"):
        np.testing.assert_array_equal(empty[name], 0.0)
    np.testing.assert_array_equal(empty["mov_p"], 1.0)


def test_the_forecast_function_gives_the_float_forecast_bit_for_bit():
    """The 12-step forecast traced into CasADi (the planner's) against the float form (the
    deployed policy's) over random filter states: the same numbers to the last bit; another
    horizon or sample time takes the float form."""
    T, H = 0.5, 12
    f = ForecastFunction(T, H)
    rng = np.random.default_rng(7)
    for _ in range(200):
        state = (*rng.normal(0.0, 5.0, 2), rng.uniform(0.0, 2.0), rng.uniform(-4.0, 4.0), rng.normal(0.0, 0.2))
        A = rng.normal(0.0, 0.3, (5, 5))
        P = A @ A.T
        cov_upper = tuple(P[np.triu_indices(5)].tolist())
        q = tuple(rng.uniform(1e-4, 1e-2, 5).tolist())
        means, covs = [], []
        propagate(*state, cov_upper, T, q, H, means, covs)
        m, c = f(state, cov_upper, T, q, H)
        assert m.shape == (H, 2) and c.shape == (H, 2, 2)
        assert m.ravel().tobytes() == np.array(means).tobytes()
        assert c.ravel().tobytes() == np.array(covs).tobytes()
    for other_T, other_H in ((T, 5), (0.25, H)):
        means, covs = [], []
        propagate(*state, cov_upper, other_T, q, other_H, means, covs)
        m, c = f(state, cov_upper, other_T, q, other_H)
        assert m.shape == (other_H, 2)
        assert m.ravel().tobytes() == np.array(means).tobytes() and c.ravel().tobytes() == np.array(covs).tobytes()
