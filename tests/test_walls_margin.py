"""The margin near walls (PlannerConfig.walls_margin_m, walls_sigmas): settings refused in
one line when wrong; the NLP of a map with walls takes the margin and its sigmas as
parameters only when the settings have one (every other NLP is the one it was); at the
open margin's values it prices every plan exactly as the NLP with the margin as constants,
and at the near ones as the NLP built with those constants; a tick is near walls when a
segment is within the check's reach."""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

casadi = pytest.importorskip("casadi")

from casadi_gpc.config import WALL_SLOTS, preset  # noqa: E402
from casadi_gpc.problem.cost import build_problem, layout_of  # noqa: E402
from casadi_gpc.problem.selection import planner_parameters  # noqa: E402
from casadi_gpc.robot import RobotParams  # noqa: E402
from casadi_gpc.geometry import walls_reach_m  # noqa: E402
from casadi_gpc.safety.walls import wall_segments_within  # noqa: E402
from casadi_gpc.types import ObstacleForecast, StaticObstacle  # noqa: E402

SHIPPED = preset("improved")
CFG = replace(SHIPPED, walls_margin_m=None, walls_sigmas=None)  # one margin everywhere
NEAR = dict(walls_margin_m=0.05, walls_sigmas=1.0)


def test_improved_plans_with_the_margin_near_walls_the_rule_adopted():
    """docs/data/buildings/walls_margin/rule3.md; the paper's preset has no margin at all."""
    assert (SHIPPED.walls_margin_m, SHIPPED.walls_sigmas) == (0.05, 1.0)
    assert (SHIPPED.clearance_margin_m, SHIPPED.uncertainty_sigmas) == (0.15, 2.0)
    assert preset("paper").walls_margin_m is None


@pytest.mark.parametrize("bad,words", [
    (dict(walls_margin_m=0.05), "go together"),
    (dict(walls_sigmas=1.0), "go together"),
    (dict(walls_margin_m=-0.05, walls_sigmas=1.0), "walls_margin_m must be finite"),
    (dict(walls_margin_m=0.05, walls_sigmas=math.nan), "walls_sigmas must be finite"),
])
def test_bad_margins_near_walls_are_refused(bad, words):
    with pytest.raises(ValueError, match=words):
        CFG.with_overrides(**bad)
    with pytest.raises(ValueError, match="set that too"):
        preset("paper").with_overrides(**NEAR)  # the paper's preset has no margin to replace


def test_only_an_nlp_with_walls_and_a_near_margin_takes_the_margin_as_parameters():
    plain, walled = layout_of(CFG), layout_of(CFG.for_walls(True))
    assert "margin" not in plain.blocks and "margin" not in walled.blocks
    assert layout_of(CFG.with_overrides(**NEAR)).blocks == plain.blocks  # no walls: the same NLP
    assert layout_of(SHIPPED).blocks == plain.blocks
    near = layout_of(CFG.with_overrides(**NEAR).for_walls(True))
    assert list(near.blocks)[-2:] == ["margin", "robot_r"] and near.size == walled.size + 2  # the radius stays last
    assert near.margin == (CFG.clearance_margin_m, CFG.uncertainty_sigmas)
    assert all(near.slices()[k] == walled.slices()[k] for k in walled.blocks if k != "robot_r")  # the rest where it was
    np.testing.assert_array_equal(near.unpack(near.pack(np.zeros(5), np.zeros((CFG.horizon, 3))))["margin"],
                                  [0.15, 2.0])
    with pytest.raises(ValueError, match="no margin parameters"):
        walled.pack(np.zeros(5), np.zeros((CFG.horizon, 3)), margin=(0.05, 1.0))


def _situation(rng, H, M, S, W):
    x0 = np.array([0.0, 0.0, 0.1, 0.3, 0.35])
    ref = np.column_stack([0.2 * np.arange(1, H + 1), np.zeros(H), np.zeros(H)])
    fcs = [ObstacleForecast(j, 0.3, rng.uniform(-1.5, 1.5, 2) + np.outer(np.arange(1, H + 1), rng.uniform(-0.3, 0.3, 2)),
                            np.tile(np.diag(rng.uniform(0.002, 0.05, 2)), (H, 1, 1))) for j in range(M)]
    statics = [StaticObstacle(tuple(rng.uniform(-1.5, 1.5, 2)), 0.2) for _ in range(S)]
    walls = [(-5.0, 0.9, 5.0, 0.9), (-5.0, -0.8, 5.0, -0.8)][:W]
    return x0, ref, fcs, statics, walls


def test_the_parameters_price_plans_as_the_constants_do():
    """Random plans near movers, a static obstacle and two walls (the beyond-horizon term on):
    the NLP with the margin as parameters, at the open values, gives every cost term bit for
    bit as the NLP with the constants; at the near values, as the NLP built with those as its
    constants (to rounding). The margin term must differ between the two, or nothing is
    compared."""
    H, M, S, W = 4, 3, 1, 2
    base = CFG.with_overrides(horizon=H, max_moving=M, max_static=S, max_walls=W, crowd_moving=None,
                              beyond_horizon_s=(1.0, 2.0))
    const = build_problem(base, RobotParams())
    param = build_problem(base.with_overrides(**NEAR), RobotParams())
    near_const = build_problem(base.with_overrides(clearance_margin_m=0.05, uncertainty_sigmas=1.0), RobotParams())
    rng = np.random.default_rng(5)
    differ = 0
    for _ in range(20):
        x0, ref, fcs, statics, walls = _situation(rng, H, M, S, W)
        u = rng.uniform(-0.2, 0.2, 2 * H)
        pc = const.layout.pack(x0, ref, fcs, statics, 0.5, None, walls)
        pp = param.layout.pack(x0, ref, fcs, statics, 0.5, None, walls)
        pn = param.layout.pack(x0, ref, fcs, statics, 0.5, None, walls, margin=(0.05, 1.0))
        open_terms = [float(t) for t in param.terms_fn(u, pp)]
        assert open_terms == [float(t) for t in const.terms_fn(u, pc)]
        near_terms = [float(t) for t in param.terms_fn(u, pn)]
        np.testing.assert_allclose(near_terms, [float(t) for t in near_const.terms_fn(u, pc)], rtol=1e-12, atol=1e-12)
        differ += near_terms[4] != open_terms[4]
    assert differ >= 10, differ


def test_a_tick_is_near_walls_within_the_check_s_reach_and_packs_the_near_margin():
    """The planner's test (:func:`planner_parameters` with the robot's reach) and the check's
    segments (:func:`wall_segments_within`) agree on either side of the reach, and the near
    margin is packed only where a wall is within it and the settings have one."""
    robot = RobotParams()
    cfg = CFG.with_overrides(**NEAR).for_walls(True)
    reach = walls_reach_m(robot, cfg.horizon * cfg.sample_time_s)
    assert reach == pytest.approx(0.8 * 6.0 + 0.35 + 1.0)
    inside = (((-3.0, reach - 0.01), (3.0, reach - 0.01)),)
    outside = (((-3.0, reach + 0.01), (3.0, reach + 0.01)),)
    ref = np.zeros((cfg.horizon + 1, 3))
    for config, walls, near in ((cfg, inside, True), (cfg, outside, False), (cfg, (), False),
                                (CFG.for_walls(True), inside, False)):  # no near margin set
        layout = layout_of(config)
        p, sel = planner_parameters(layout, np.zeros(5), ref, [], [], config, None, walls, reach)
        assert sel.near_walls is near
        if walls:
            assert (len(wall_segments_within(walls, (0.0, 0.0), reach)) > 0) is (walls is inside)
        if layout.margin is not None:
            np.testing.assert_array_equal(layout.unpack(p)["margin"], [0.05, 1.0] if near else [0.15, 2.0])
    assert cfg.max_walls == WALL_SLOTS


@pytest.mark.parametrize("bad,words", [
    (dict(walls_sigma_cap_m=0.1), "set walls_margin_m too"),
    (dict(walls_sigma_cap_m=-0.1, **NEAR), "walls_sigma_cap_m must be finite"),
    (dict(walls_sigma_cap_m=math.inf, **NEAR), "walls_sigma_cap_m must be finite"),
])
def test_bad_sigma_caps_near_walls_are_refused(bad, words):
    with pytest.raises(ValueError, match=words):
        CFG.with_overrides(**bad)


def _growing(rng, H, j):
    """A forecast whose deviation grows from a few cm to about half a metre over the horizon,
    its covariance not isotropic."""
    a = rng.uniform(0.5, 1.5)
    covs = np.array([np.diag([(0.04 * k) ** 2 * a, (0.04 * k) ** 2 / a]) + 1e-4 * k * np.array([[0, 1], [1, 0]])
                     for k in range(1, H + 1)])
    return ObstacleForecast(j, 0.3, np.array([0.6, 0.8]) + np.outer(np.arange(1, H + 1), rng.uniform(-0.2, 0.2, 2)), covs)


def test_the_sigma_cap_near_walls_caps_the_margin_s_deviation_and_nothing_else():
    """Near a wall, with ``walls_sigma_cap_m``: the movers' deviations packed for the margin
    are min(worst deviation, cap), the worst deviation computed here from the covariances'
    eigenvalues; the margin term of every plan is the one of the same NLP handed covariances
    whose worst deviation is the capped one (isotropic where capped), and every other term
    is unchanged. Away from walls, or without the cap, the forecast's own deviations."""
    H, M, W = 12, 3, 2
    robot = RobotParams()
    cfg = CFG.with_overrides(horizon=H, max_moving=M, max_walls=W, crowd_moving=None, **NEAR)
    capped = cfg.with_overrides(walls_sigma_cap_m=0.1)
    problem = build_problem(cfg, robot)
    layout = problem.layout
    reach = walls_reach_m(robot, H * cfg.sample_time_s)
    rng = np.random.default_rng(3)
    x0 = np.array([0.0, 0.0, 0.1, 0.3, 0.35])
    ref = np.column_stack([0.2 * np.arange(H + 1), np.zeros(H + 1), np.zeros(H + 1)])
    near_walls = (((-5.0, 0.9), (5.0, 0.9)), ((-5.0, -0.8), (5.0, -0.8)))
    far_walls = (((-5.0, reach + 1.0), (5.0, reach + 1.0)),)
    fcs = [_growing(rng, H, j) for j in range(M)]
    worst = np.sqrt(np.array([[np.linalg.eigvalsh(c).max() for c in f.covs_m2] for f in fcs]))
    assert (worst > 0.1).any() and (worst < 0.1).any()  # some steps capped, some not
    sig = lambda p: layout.unpack(p)["mov_sigma"].reshape(M, H)  # noqa: E731
    p_cap, sel = planner_parameters(layout, x0, ref, fcs, [], capped, None, near_walls, reach)
    assert sel.near_walls
    np.testing.assert_allclose(sig(p_cap), np.minimum(worst, 0.1), rtol=1e-12, atol=1e-15)
    p_open, _ = planner_parameters(layout, x0, ref, fcs, [], cfg, None, near_walls, reach)
    np.testing.assert_allclose(sig(p_open), worst, rtol=1e-12, atol=1e-15)
    p_far, sel_far = planner_parameters(layout_of(capped.with_overrides(max_walls=W)), x0, ref, fcs, [], capped, None,
                                        far_walls, reach)
    assert not sel_far.near_walls
    np.testing.assert_allclose(sig(p_far), worst, rtol=1e-12, atol=1e-15)
    # the margin term as if the forecasts were that sure of themselves; the rest unchanged
    sure = [ObstacleForecast(f.obstacle_id, f.radius_m, f.means_m,
                             np.array([c if w <= 0.1 else 0.01 * np.eye(2) for c, w in zip(f.covs_m2, ws)]))
            for f, ws in zip(fcs, worst)]
    p_sure, _ = planner_parameters(layout, x0, ref, sure, [], cfg, None, near_walls, reach)
    differ = 0
    for _ in range(20):
        u = rng.uniform(-0.2, 0.2, 2 * H)
        t_cap = [float(t) for t in problem.terms_fn(u, p_cap)]
        t_open = [float(t) for t in problem.terms_fn(u, p_open)]
        t_sure = [float(t) for t in problem.terms_fn(u, p_sure)]
        assert t_cap[4] == pytest.approx(t_sure[4], rel=1e-12, abs=1e-12)
        assert t_cap[:4] == t_open[:4] and t_cap[5:] == t_open[5:]
        differ += t_cap[4] != t_open[4]
    assert differ >= 10, differ


def test_the_directional_deviation_is_refused_without_a_margin_near_walls_or_with_a_cap():
    with pytest.raises(ValueError, match="set walls_margin_m too"):
        CFG.with_overrides(walls_directional_sigma=True)
    with pytest.raises(ValueError, match="set one"):
        CFG.with_overrides(walls_directional_sigma=True, walls_sigma_cap_m=0.1, **NEAR)


def test_the_directional_deviation_prices_the_margin_along_the_line_to_the_robot():
    """With ``walls_directional_sigma``: the NLP of a map with walls takes the forecasts'
    covariances and a switch; switched off (a tick away from walls) it prices every plan bit
    for bit as the NLP without the option; switched on (near walls: ``planner_parameters``
    sets it), its margin term is the one computed here in numpy from the roll-out's positions,
    each mover's margin inflated by sqrt(u' C u) along the line u from it to the robot; and
    that is never more than with the worst deviation, and less in most plans."""
    H, M, W = 12, 3, 2
    robot = RobotParams()
    base = CFG.with_overrides(horizon=H, max_moving=M, max_walls=W, crowd_moving=None, **NEAR)
    cfg = base.with_overrides(walls_directional_sigma=True)
    plain, directional = build_problem(base, robot), build_problem(cfg, robot)
    assert "dir" not in plain.layout.blocks and directional.layout.blocks["mov_cov"] == (M, H, 3)
    assert "dir" not in layout_of(CFG.with_overrides(walls_directional_sigma=True, **NEAR)).blocks  # no walls
    reach = walls_reach_m(robot, H * cfg.sample_time_s)
    near_walls = (((-5.0, 0.9), (5.0, 0.9)), ((-5.0, -0.8), (5.0, -0.8)))
    far_walls = (((-5.0, reach + 1.0), (5.0, reach + 1.0)),)
    rng = np.random.default_rng(11)
    x0 = np.array([0.0, 0.0, 0.1, 0.3, 0.35])
    ref = np.column_stack([0.2 * np.arange(H + 1), np.zeros(H + 1), np.zeros(H + 1)])
    e, pen = cfg.margin_smoothing_m, cfg.clearance_penalty
    smaller = 0
    for _ in range(12):
        fcs = [_growing(rng, H, j) for j in range(M)]
        u = rng.uniform(-0.2, 0.2, 2 * H)
        # away from walls: the switch off, every term as the NLP without the option
        p_off, sel = planner_parameters(directional.layout, x0, ref, fcs, [], cfg, None, far_walls, reach)
        p_plain, _ = planner_parameters(plain.layout, x0, ref, fcs, [], base, None, far_walls, reach)
        assert not sel.near_walls and directional.layout.unpack(p_off)["dir"][0] == 0.0
        assert [float(t) for t in directional.terms_fn(u, p_off)] == [float(t) for t in plain.terms_fn(u, p_plain)]
        # near walls: the switch on
        p_on, sel = planner_parameters(directional.layout, x0, ref, fcs, [], cfg, None, near_walls, reach)
        p_worst, _ = planner_parameters(plain.layout, x0, ref, fcs, [], base, None, near_walls, reach)
        assert sel.near_walls and directional.layout.unpack(p_on)["dir"][0] == 1.0
        t_on = [float(t) for t in directional.terms_fn(u, p_on)]
        t_worst = [float(t) for t in plain.terms_fn(u, p_worst)]
        assert t_on[:4] == t_worst[:4]
        xy = np.asarray(plain.rollout_fn(u, p_worst)[0])[:, :2]  # the robot after steps 1..H
        expected = 0.0
        for f in fcs:
            for i in range(H):
                r = xy[i] - f.means_m[i]
                dist = np.hypot(*r)
                d = dist - robot.radius_m - f.radius_m
                along = np.sqrt(r @ f.covs_m2[i] @ r / dist ** 2)
                worst = np.sqrt(np.linalg.eigvalsh(f.covs_m2[i]).max())
                for sigma, sign in ((along, 1.0), (worst, -1.0)):
                    x = 0.05 + 1.0 * sigma - d
                    expected += sign * pen * (0.5 * (x + np.sqrt(x * x + e * e))) ** 2
        # the walls' margin terms are the same in both: the difference is the movers' alone
        assert t_on[4] - t_worst[4] == pytest.approx(expected, rel=1e-7, abs=1e-9)
        assert t_on[4] <= t_worst[4] + 1e-12
        smaller += t_on[4] < t_worst[4] - 1e-9
    assert smaller >= 6, smaller
