"""The GPC's optimum against an independent solver.

The cost is written again here in numpy, from the paper's formula and the documented
settings of the presets (PlannerConfig's docstrings), with its own rollout, its own P and
its own clearance; it is checked against the CasADi cost at random points, then scipy's
SLSQP minimises it under the same bounds and linear wheel-speed limits from several starts.
The GPC's best plan must not be worse than scipy's by more than 1e-6 relative.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import LinearConstraint, minimize

from casadi_gpc.config import PRESETS
from casadi_gpc.planner.gpc import GPCController
from casadi_gpc.planner.guesses import initial_guesses
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams
from casadi_gpc.types import ObstacleForecast, StaticObstacle


# --- an independent numpy implementation of the cost ------------------------------------
def numpy_cost(u, x0, ref, forecasts, statics, cfg, robot: RobotParams):
    """J(u) for increments ``u`` of shape (..., 2H) (vectorised over the leading axes)."""
    return make_numpy_cost(x0, ref, forecasts, statics, cfg, robot)(u)


def make_numpy_cost(x0, ref, forecasts, statics, cfg, robot: RobotParams):
    """The cost of one tick as a function of the increments alone (obstacle terms prepared once)."""
    H = cfg.horizon
    obstacles = []  # (positions (H, 2), radius, P (H,), sigma (H,), xi)
    for f in forecasts:
        p_unc = 1.0 + (f.covs_m2[:, 0, 0] + f.covs_m2[:, 1, 1]) / cfg.uncertainty_scale_m ** 2
        sigma = np.sqrt([np.max(np.linalg.eigvalsh(c)) for c in f.covs_m2])
        obstacles.append((f.means_m, f.radius_m, p_unc, sigma, cfg.xi_moving))
    for s in statics:
        obstacles.append((np.tile(s.position_m, (H, 1)), s.radius_m, np.ones(H), np.zeros(H), cfg.xi_static))
    return lambda u: _cost(np.asarray(u, dtype=float), x0, ref, obstacles, cfg, robot)


def _cost(u, x0, ref, obstacles, cfg, robot):
    H, T, W = cfg.horizon, cfg.sample_time_s, robot.wheel_base_m
    du = u.reshape(u.shape[:-1] + (H, 2))
    vr = x0[3] + np.cumsum(du[..., 0], axis=-1)
    vl = x0[4] + np.cumsum(du[..., 1], axis=-1)
    v, a = 0.5 * (vr + vl), (vr - vl) / W
    # exact arcs: the chord is V T sin(A T/2)/(A T/2), along the mid-interval heading
    chord = v * T * np.sinc(a * T / 2 / np.pi)
    x = np.empty_like(vr)
    y = np.empty_like(vr)
    th = np.empty_like(vr)
    px, py, ph = (np.full(u.shape[:-1], x0[k]) for k in range(3))
    for i in range(H):
        px = px + chord[..., i] * np.cos(ph + a[..., i] * T / 2)
        py = py + chord[..., i] * np.sin(ph + a[..., i] * T / 2)
        ph = ph + a[..., i] * T
        x[..., i], y[..., i], th[..., i] = px, py, ph
    e_h = np.mod(th - ref[:, 2] + np.pi, 2 * np.pi) - np.pi
    J = np.sum(cfg.tracking_weight * ((x - ref[:, 0]) ** 2 + (y - ref[:, 1]) ** 2) + cfg.heading_weight * e_h ** 2,
               axis=-1)
    J = J + cfg.lambda1 * np.sum(du ** 2, axis=(-1, -2)) + cfg.lambda2 * np.sum((vr - vl) ** 2, axis=-1)
    eps = cfg.clearance_softening_m
    for pos, radius, p_unc, sigma, xi in obstacles:
        d = np.hypot(x - pos[:, 0], y - pos[:, 1]) - robot.radius_m - radius
        d_eff = 0.5 * (d + np.sqrt(d * d + eps * eps))
        if cfg.influence_m is None:
            J = J + np.sum(xi / (p_unc * d_eff ** 2), axis=-1)
        else:
            J = J + np.sum(xi / p_unc * np.maximum(1.0 / d_eff - 1.0 / cfg.influence_m, 0.0) ** 2, axis=-1)
        if cfg.clearance_margin_m is not None:
            m = cfg.clearance_margin_m + cfg.uncertainty_sigmas * sigma
            e = cfg.margin_smoothing_m
            viol = np.maximum(m - d, 0.0) if e is None else 0.5 * ((m - d) + np.sqrt((m - d) ** 2 + e * e))
            J = J + np.sum(cfg.clearance_penalty * viol ** 2, axis=-1)
    return J


# --- random problems ----------------------------------------------------------------
def random_problem(rng: np.random.Generator, cfg, robot: RobotParams, n_moving: int, n_static: int):
    """x0, desired poses, forecasts and statics of a plausible tick with obstacles ahead."""
    H, T = cfg.horizon, cfg.sample_time_s
    vmax = robot.max_wheel_speed_mps
    speed = rng.uniform(0.25, 0.5)
    curv = rng.choice([0.0, rng.uniform(-0.3, 0.3)])
    path = ReferencePath((0.0, 0.0), 0.0, (Segment.line(2.0), Segment(30.0, curv)), speed)
    s0 = rng.uniform(0.0, 1.0)
    px, py, ph = path.pose_at_arclength(s0)
    off = rng.uniform(-0.5, 0.5)
    vr, vl = rng.uniform(0.0, vmax, 2) if rng.random() < 0.8 else rng.uniform(-0.3, 0.3, 2)
    x0 = np.array([px - off * np.sin(ph) - rng.uniform(0, 0.5), py + off * np.cos(ph), ph + rng.uniform(-0.5, 0.5),
                   vr, vl])
    ref = path.pose_at_arclength(s0 + speed * T * np.arange(1, H + 1))
    forecasts = []
    for j in range(n_moving):
        while True:
            ahead = rng.uniform(1.5, 5.0)
            ox, oy, oh = path.pose_at_arclength(s0 + ahead)
            lateral = rng.uniform(-1.0, 1.0)
            start = np.array([ox - lateral * np.sin(oh), oy + lateral * np.cos(oh)])
            if np.hypot(*(start - x0[:2])) > robot.radius_m + 0.5 + 0.3:
                break
        heading = oh + np.pi + rng.uniform(-1.2, 1.2)  # roughly towards the robot
        vel = rng.uniform(0.0, 0.5) * np.array([np.cos(heading), np.sin(heading)])
        k = np.arange(1, H + 1)[:, None]
        means = start + vel * T * k
        a = rng.normal(0.0, 0.02, (2, 2))
        covs = np.array([(0.02 ** 2 + (0.03 * i) ** 2) * np.eye(2) + a @ a.T for i in range(1, H + 1)])
        forecasts.append(ObstacleForecast(j, float(rng.uniform(0.2, 0.4)), means, covs))
    statics = []
    for _ in range(n_static):
        while True:
            sx, sy, sh = path.pose_at_arclength(s0 + rng.uniform(1.0, 4.0))
            lat = rng.choice([-1, 1]) * rng.uniform(0.2, 1.5)
            pos = (float(sx - lat * np.sin(sh)), float(sy + lat * np.cos(sh)))
            if np.hypot(pos[0] - x0[0], pos[1] - x0[1]) > robot.radius_m + 0.4 + 0.3:
                break
        statics.append(StaticObstacle(pos, float(rng.uniform(0.15, 0.4))))
    return x0, ref, forecasts, statics, speed


def feasible_random_start(rng, x0, H, dv, vmax):
    u = rng.uniform(-dv, dv, (H, 2))
    v = x0[3:5].copy()
    for i in range(H):
        u[i] = np.clip(v + u[i], -vmax, vmax) - v
        v = v + u[i]
    return u.reshape(-1)


def scipy_minimum(fun, starts, H, x0, dv, vmax):
    """The best SLSQP result over ``starts``, under the GPC's bounds and linear limits."""
    L = np.zeros((2 * H, 2 * H))  # wheel speeds = x0 wheels + cumulative sums of increments
    for i in range(H):
        for k in range(i + 1):
            L[2 * i, 2 * k] = L[2 * i + 1, 2 * k + 1] = 1.0
    v0 = np.tile(x0[3:5], H)
    lin = LinearConstraint(L, -vmax - v0, vmax - v0)

    def grad(u, h=1e-6):
        e = np.eye(len(u)) * h
        f = fun(np.concatenate([u + e, u - e]))
        return (f[: len(u)] - f[len(u):]) / (2 * h)

    best = None
    for u0 in starts:
        res = minimize(lambda u: float(fun(u)), u0, jac=grad, method="SLSQP", bounds=[(-dv, dv)] * (2 * H),
                       constraints=[lin], options={"ftol": 1e-15, "maxiter": 1000})
        u = np.clip(res.x, -dv, dv)
        if np.any(np.abs(L @ u + v0) > vmax + 1e-9):
            continue
        f = float(fun(u))
        if best is None or f < best[0]:
            best = (f, u)
    return best


CONTROLLERS = {}


def controller(name: str) -> GPCController:
    if name not in CONTROLLERS:
        CONTROLLERS[name] = GPCController(PRESETS[name], RobotParams())
    return CONTROLLERS[name]


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_numpy_cost_equals_casadi_cost(name):
    ctrl = controller(name)
    cfg, robot, pr = ctrl.config, ctrl.robot, ctrl.problem
    H = cfg.horizon
    dv, vmax = robot.max_step_change_mps(cfg.sample_time_s), robot.max_wheel_speed_mps
    rng = np.random.default_rng(100)
    compared = 0
    for k in range(30):
        x0, ref, forecasts, statics, _ = random_problem(rng, cfg, robot, 1 + k % 2, k % 3)
        p = pr.layout.pack(x0, ref, forecasts, statics, cfg.uncertainty_scale_m)
        for u in [np.zeros(2 * H), feasible_random_start(rng, x0, H, dv, vmax),
                  rng.uniform(-dv, dv, 2 * H), np.repeat(rng.uniform(-dv, dv), 2 * H)]:  # last: Vr - Vl constant
            want = float(pr.cost_fn(u, p))
            got = float(numpy_cost(u, x0, ref, forecasts, statics, cfg, robot))
            assert got == pytest.approx(want, rel=1e-9, abs=1e-12), (k, got, want)
            compared += 1
        # vectorised evaluation agrees with the one-by-one evaluation
        us = rng.uniform(-dv, dv, (3, 2 * H))
        np.testing.assert_allclose(numpy_cost(us, x0, ref, forecasts, statics, cfg, robot),
                                   [float(numpy_cost(u, x0, ref, forecasts, statics, cfg, robot)) for u in us],
                                   rtol=1e-14)
    assert compared == 120


def test_numpy_cost_sees_each_term():
    """The independent cost is sensitive to every term (so agreement is not an accident):
    switching an obstacle off or changing a weight changes both costs alike."""
    ctrl = controller("paper")
    cfg, robot, pr = ctrl.config, ctrl.robot, ctrl.problem
    rng = np.random.default_rng(4)
    x0, ref, forecasts, statics, _ = random_problem(rng, cfg, robot, 2, 1)
    u = feasible_random_start(rng, x0, cfg.horizon, 0.5, 0.8)
    full = float(numpy_cost(u, x0, ref, forecasts, statics, cfg, robot))
    for f_sub, s_sub in ((forecasts[:1], statics), (forecasts, []), ([], [])):
        p = pr.layout.pack(x0, ref, f_sub, s_sub, cfg.uncertainty_scale_m)
        got = float(numpy_cost(u, x0, ref, f_sub, s_sub, cfg, robot))
        assert got < full
        assert got == pytest.approx(float(pr.cost_fn(u, p)), rel=1e-9)


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_gpc_optimum_not_worse_than_scipy(name):
    ctrl = controller(name)
    cfg, robot, pr = ctrl.config, ctrl.robot, ctrl.problem
    H = cfg.horizon
    dv, vmax = robot.max_step_change_mps(cfg.sample_time_s), robot.max_wheel_speed_mps
    rng = np.random.default_rng(2024)
    report = []
    for k in range(8):
        x0, ref, forecasts, statics, speed = random_problem(rng, cfg, robot, 1 + k % 2, k % 2)
        p = pr.layout.pack(x0, ref, forecasts, statics, cfg.uncertainty_scale_m)
        best, candidates = ctrl.plan(p, x0, speed, multistart=True, warm=None)
        assert best is not None and best.success, [c.status for c in candidates]
        guesses = initial_guesses(pr, x0, speed, ref)
        assert len(candidates) == len(guesses) >= 3
        # the GPC's plan is feasible and its reported cost is the cost of its plan
        assert np.all(np.abs(best.u) <= dv + 1e-8)
        wheels = x0[3:5] + np.cumsum(best.u.reshape(H, 2), axis=0)
        assert np.all(np.abs(wheels) <= vmax + 1e-8)

        fun = make_numpy_cost(x0, ref, forecasts, statics, cfg, robot)
        gpc_cost = float(fun(best.u))
        assert gpc_cost == pytest.approx(best.cost, rel=1e-9)
        starts = [np.zeros(2 * H)] + list(guesses.values())  # scipy from the GPC's starts, and more
        starts += [feasible_random_start(rng, x0, H, dv, vmax) for _ in range(3)]
        sp_cost, _ = scipy_minimum(fun, starts, H, x0, dv, vmax)
        report.append((gpc_cost, sp_cost))
        assert gpc_cost <= sp_cost + 1e-6 * abs(sp_cost), (k, gpc_cost, sp_cost)
    # and they agree (not merely "not worse") on most problems: the same optimum
    agree = [abs(g - s) <= 1e-6 * abs(s) for g, s in report]
    assert sum(agree) >= len(report) - 1, report


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_symmetric_head_on_passes_on_the_right_every_time(name):
    """A head-on obstacle on a straight path is mirror-symmetric: both swerves cost the same
    (checked with the numpy cost), and the GPC breaks the tie the same way every time, to the
    right, and not by stopping."""
    ctrl = controller(name)
    cfg, robot, pr = ctrl.config, ctrl.robot, ctrl.problem
    H, T = cfg.horizon, cfg.sample_time_s
    x0 = np.array([0.0, 0.0, 0.0, 0.4, 0.4])
    ref = np.stack([0.4 * T * np.arange(1, H + 1), np.zeros(H), np.zeros(H)], axis=1)
    k = np.arange(1, H + 1)[:, None]
    ahead = 0.8 * 0.4 * H * T + 1.0
    means = np.array([ahead, 0.0]) + np.array([-0.3, 0.0]) * T * k
    covs = np.array([(0.02 ** 2 + (0.02 * i) ** 2) * np.eye(2) for i in range(1, H + 1)])
    forecasts = [ObstacleForecast(0, 0.3, means, covs)]
    p = pr.layout.pack(x0, ref, forecasts, [], cfg.uncertainty_scale_m)
    plans = [ctrl.plan(p, x0, 0.4, multistart=True, warm=None)[0] for _ in range(3)]
    for plan in plans[1:]:
        np.testing.assert_array_equal(plan.u, plans[0].u)
    poses = np.asarray(pr.rollout_fn(plans[0].u, p)[0])
    assert poses[:, 1].min() < -1e-3 and poses[:, 1].max() <= 1e-9  # to the right, only
    mirrored = plans[0].u.reshape(H, 2)[:, ::-1].reshape(-1)  # swap the wheels: the mirror image
    assert float(numpy_cost(mirrored, x0, ref, forecasts, [], cfg, robot)) == pytest.approx(plans[0].cost, rel=1e-9)
    assert poses[-1, 0] > 0.5 * 0.4 * H * T  # it keeps going
