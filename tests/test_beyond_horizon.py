"""The margin beyond the horizon (``PlannerConfig.beyond_horizon_s``): the robot standing
where the plan leaves it, each mover carried on straight at its forecast's last velocity.
The NLP's term against the formula written out in numpy; its place in the cost; the
settings it refuses."""
from __future__ import annotations

import numpy as np
import pytest

from casadi_gpc.config import PRESETS, PlannerConfig
from casadi_gpc.problem.cost import build_problem
from casadi_gpc.robot import RobotParams
from casadi_gpc.types import ObstacleForecast

BEYOND = (1.0, 2.0, 3.0)


def _numpy_beyond(cfg: PlannerConfig, robot: RobotParams, end_xy, forecasts) -> float:
    """The term written out: for each mover and instant s, the smoothed violation of the
    margin (its sigma at the horizon's last step) by the distance from the plan's last
    position to the mover's last forecast position plus s times its last step's velocity."""
    total, e = 0.0, cfg.margin_smoothing_m
    for f in forecasts:
        last, before = f.means_m[-1], f.means_m[-2]
        v = (last - before) / cfg.sample_time_s
        sigma = np.sqrt(np.linalg.eigvalsh(f.covs_m2[-1]).max())
        m = cfg.clearance_margin_m + cfg.uncertainty_sigmas * sigma
        for s in cfg.beyond_horizon_s:
            d = np.hypot(*(end_xy - last - v * s)) - robot.radius_m - f.radius_m
            viol = 0.5 * ((m - d) + np.sqrt((m - d) ** 2 + e * e))
            total += cfg.clearance_penalty * viol ** 2
    return total


def _head_on(cfg: PlannerConfig, rng, n: int):
    H = cfg.horizon
    forecasts = []
    for j in range(n):
        start = np.array([rng.uniform(2.0, 5.0), rng.normal(0.0, 0.5)])
        vel = np.array([-rng.uniform(0.1, 0.8), rng.normal(0.0, 0.1)])
        means = start + np.outer(np.arange(1, H + 1) * cfg.sample_time_s, vel)
        cov = np.array([np.eye(2) * (0.01 + 0.002 * k) for k in range(1, H + 1)])
        forecasts.append(ObstacleForecast(j, rng.uniform(0.2, 0.35), means, cov))
    return forecasts


def test_the_nlps_term_is_the_formula_written_out():
    """The margin term of the NLP with the setting, less the one without it, is the formula
    in numpy at the plan's last position, at random plans among movers walking at the robot
    (some of them stopped short of it within the horizon, reaching it beyond)."""
    base = PRESETS["improved"].with_overrides(max_moving=4, crowd_moving=None)
    with_it = base.with_overrides(beyond_horizon_s=BEYOND)
    robot = RobotParams()
    p_with, p_without = build_problem(with_it, robot), build_problem(base, robot)
    rng = np.random.default_rng(7)
    H, dv = with_it.horizon, p_with.ubx[0]
    x0 = np.array([0.0, 0.0, 0.0, 0.3, 0.3])
    ref = np.column_stack([np.linspace(0.2, 2.4, H), np.zeros(H), np.zeros(H)])
    seen_positive = 0
    for _ in range(30):
        forecasts = _head_on(with_it, rng, int(rng.integers(1, 5)))
        p = p_with.layout.pack(x0, ref, forecasts, [], with_it.uncertainty_scale_m, None)
        u = rng.uniform(-dv, dv, p_with.n_u)
        extra = float(p_with.terms_fn(u, p)[4]) - float(p_without.terms_fn(u, p)[4])
        end = np.asarray(p_with.rollout_fn(u, p)[0]).reshape(-1, 3)[-1, :2]
        expected = _numpy_beyond(with_it, robot, end, forecasts)
        assert extra == pytest.approx(expected, rel=1e-9, abs=1e-9)
        seen_positive += expected > 1.0
        # the other terms are untouched
        for k in range(4):
            assert float(p_with.terms_fn(u, p)[k]) == float(p_without.terms_fn(u, p)[k])
    assert seen_positive >= 5  # the cases include plans that end in a mover's way


def test_a_plan_that_ends_in_a_movers_way_pays_and_one_beside_it_does_not():
    """A walker 3 m ahead coming at 0.4 m/s: within the 6 s horizon it stops 0.6 m short of
    where a plan that stands still leaves the robot, so the horizon's own margin is kept;
    beyond it the robot is in its way. Standing aside by 1 m costs nothing there."""
    cfg = PRESETS["improved"].with_overrides(max_moving=1, crowd_moving=None, beyond_horizon_s=BEYOND)
    robot = RobotParams()
    H, T = cfg.horizon, cfg.sample_time_s
    means = np.array([4.0, 0.0]) + np.outer(np.arange(1, H + 1) * T, [-0.4, 0.0])
    walker = ObstacleForecast(0, 0.25, means, np.array([np.eye(2) * 1e-4] * H))
    for where, pays in (((0.0, 0.0), True), ((0.0, 1.0), False)):
        total = _numpy_beyond(cfg, robot, np.array(where), [walker])
        assert (total > 100.0) if pays else (total < 0.1)  # the smoothing's tail only
    # the horizon's own margin at the standing robot's last step is kept
    d_last = np.hypot(*means[-1]) - robot.radius_m - 0.25
    assert d_last > cfg.clearance_margin_m + 0.1


def test_the_paper_keeps_the_horizon_alone_and_bad_settings_are_refused():
    assert PRESETS["paper"].beyond_horizon_s == ()
    for bad in ((0.0,), (-1.0,), (float("nan"),), (1.0, float("inf"))):
        with pytest.raises(ValueError, match="beyond_horizon_s"):
            PlannerConfig(name="x", sample_time_s=0.5, beyond_horizon_s=bad)
