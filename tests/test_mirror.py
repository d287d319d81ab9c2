"""Mirror symmetry: the GPC's answer on a situation reflected about the reference's tangent
is the original answer with the wheels swapped, to 1e-6 m/s on random situations (the check
the dataset writer applies to its labels), and the dataset's mirror samples are exactly the
mirror map of their partners."""
from __future__ import annotations

import numpy as np
import pytest

from casadi_gpc.config import preset
from nn_export.runtime.features import compute_features, mirror_features
from nn_export.runtime.layouts import layout_for
from nn_export.training.labels import FALLBACK_SOLVER, Labeller, fitted_slots, mirror_label
from nn_export.training.sampler import sample_situation

TOL_MPS = 1e-6


@pytest.fixture(scope="module")
def labellers():
    return {}


def _labeller(cache, name):
    if name not in cache:
        cache[name] = Labeller(preset(name))
    return cache[name]


def _mirror_pairs(lab, layout_name, count, seed=2024):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        sit = sample_situation(rng, lab.config, layout_name)
        yield lab.label(sit), lab.label(sit.mirrored())


def test_gpc_answer_is_mirror_symmetric_paper_preset(labellers):
    """Under the paper's preset every answer is mirror-symmetric to 1e-6 m/s."""
    lab = _labeller(labellers, "paper")
    checked = 0
    for a, b in _mirror_pairs(lab, "paper", 40):
        assert a.converged == b.converged
        if not a.converged:
            continue
        diff = float(np.max(np.abs(mirror_label(a.wheels_mps) - b.wheels_mps)))
        assert diff <= TOL_MPS, (diff, a.guess, b.guess, a.candidate_costs, b.candidate_costs)
        assert b.cost == pytest.approx(a.cost, rel=1e-9, abs=1e-12)
        np.testing.assert_allclose(mirror_label(a.plan_wheels_mps), b.plan_wheels_mps, atol=1e-5)
        checked += 1
    assert checked >= 38


@pytest.mark.parametrize("layout_name, count", [("paper", 30), ("multi", 20)])
def test_gpc_answer_is_mirror_symmetric_improved_preset(labellers, layout_name, count):
    """Under ``improved`` nearly every answer is mirror-symmetric to 1e-6 m/s. The exceptions
    measured (about 1-3 % of sampled situations, nearly all with the obstacle already inside
    the clearance margin) are of two kinds only: the two sides' multi-starts reach different
    optima (never a tie: the dataset writer keeps the cheaper one for both), or one optimum
    reached to the SQP's own tolerance (costs equal to 1e-7, answers within 1e-4 m/s). Plans
    are compared whole: two optima may share a first control saturated at the acceleration
    limit (braking hard, then waiting or swerving)."""
    lab = _labeller(labellers, "improved")
    symmetric = other = 0
    for a, b in _mirror_pairs(lab, layout_name, count):
        if not (a.converged and b.converged):
            continue
        diff = float(np.max(np.abs(mirror_label(a.plan_wheels_mps) - b.plan_wheels_mps)))
        if diff <= TOL_MPS:
            assert b.cost == pytest.approx(a.cost, rel=1e-7, abs=1e-9)
            symmetric += 1
            continue
        other += 1
        different_optima = abs(a.cost - b.cost) > 1e-7 * abs(a.cost)
        solver_precision = not different_optima and diff <= 1e-4
        assert different_optima or solver_precision, (diff, a.cost, b.cost)
    assert symmetric >= count - 3 and other <= max(1, count // 10)


def test_mirror_map_swaps_wheels_and_negates_lateral_quantities():
    lay = layout_for("paper", 6)
    f = np.arange(1.0, lay.size + 1.0)
    f[lay.index("mov1_heading_rad")] = 1.0
    m = dict(zip(lay.feature_names, mirror_features(lay, f)))
    orig = dict(zip(lay.feature_names, f))
    assert (m["v_right_prev_mps"], m["v_left_prev_mps"]) == (orig["v_left_prev_mps"], orig["v_right_prev_mps"])
    for name in lay.feature_names:
        if name.endswith(("_y_m", "_turn_rad")) or name.startswith("ref_curvature") or name == "ref_heading_rad":
            assert m[name] == -orig[name], name
        elif name == "mov1_heading_rad":
            assert m[name] == pytest.approx(2 * np.pi - 1.0)
        elif name not in ("v_right_prev_mps", "v_left_prev_mps"):
            assert m[name] == orig[name], name
    np.testing.assert_array_equal(mirror_label(np.array([[0.3, 0.1]])), [[0.1, 0.3]])


def test_mirror_samples_in_a_shard_are_the_mirror_of_their_partners(labellers):
    from nn_export.training.dataset import DatasetSpec, label_shard
    cfg = preset("paper")
    spec = DatasetSpec(samples=16, config=cfg, layout=layout_for("paper", cfg.horizon), seed=4, shard_size=16,
                       solver=_labeller(labellers, "paper").solver, mirror_check_every=2)
    _, a, stats = label_shard(spec, 0)
    lay = spec.layout
    orig, mir = ~a["mirror"], a["mirror"]
    assert orig.sum() == mir.sum() == 8
    np.testing.assert_array_equal(a["situation_id"][orig], a["situation_id"][mir])
    np.testing.assert_allclose(a["features"][mir], mirror_features(lay, a["features"][orig]), atol=0, rtol=0)
    np.testing.assert_array_equal(a["labels"][mir], a["labels"][orig][:, ::-1])
    np.testing.assert_array_equal(a["plan_wheels_mps"][mir], a["plan_wheels_mps"][orig][:, :, ::-1])
    # the writer's own check ran on every second situation and found the labels symmetric
    checks = a["mirror_check_mps"][orig][::2]
    assert np.all(np.isfinite(checks)) and np.all(checks <= TOL_MPS)
    assert stats["mirror_checked"] == 4 and stats["mirror_over_tolerance"] == 0
    # and the stored features are those of the situations themselves
    rng = np.random.default_rng([4, 0])
    first = sample_situation(rng, cfg, "paper")
    np.testing.assert_array_equal(a["features"][0], compute_features(lay, first))


@pytest.mark.parametrize("preset_name", ["paper", "improved"])
def test_known_answer_label_on_the_reference_without_obstacles(labellers, preset_name):
    """A robot on a straight reference at the reference speed, nothing around: the GPC keeps
    both wheels at that speed (every cost term is zero there), and the features say so."""
    import math

    from casadi_gpc.reference import ReferencePath, Segment
    from casadi_gpc.robot import RobotState
    from nn_export.runtime.situation import Situation, reference_poses
    lab = _labeller(labellers, preset_name)
    cfg = lab.config
    path = ReferencePath((0.0, 0.0), 0.3, (Segment.line(40.0),), 0.4)
    x, y, h = (float(v) for v in path.pose_at_arclength(5.0))
    ref = reference_poses(path, 5.0, cfg.sample_time_s, cfg.horizon)
    sit = Situation(RobotState(x, y, h, 0.4, 0.4), ref, cfg.sample_time_s, 0.4)
    a = lab.label(sit)
    assert a.converged and a.cost == pytest.approx(0.0, abs=1e-10)
    np.testing.assert_allclose(a.plan_wheels_mps, 0.4, atol=1e-6)
    lay = layout_for("paper", cfg.horizon)
    f = dict(zip(lay.feature_names, compute_features(lay, sit)))
    assert f["ref_x_m"] == pytest.approx(0.4 * cfg.sample_time_s) and f["ref_speed_mps"] == pytest.approx(0.4)
    assert math.isclose(f["ref_y_m"], 0.0, abs_tol=1e-12)


# --- the labeller's NLP fitted to the obstacles selected -----------------------------------

def _same_label(a, b, tol=1e-12):
    """Two labels of one situation agree to ``tol`` (plan, cost, candidate costs, guess, side)."""
    assert a.converged == b.converged and a.guess == b.guess and a.solver == b.solver and a.side == b.side
    np.testing.assert_allclose(a.plan_wheels_mps, b.plan_wheels_mps, rtol=0, atol=tol)
    np.testing.assert_allclose(a.candidate_costs, b.candidate_costs, rtol=0, atol=tol)  # NaN where NaN
    if a.converged:
        assert abs(a.cost - b.cost) <= tol
    assert (a.alternative is None) == (b.alternative is None)
    if a.alternative is not None:
        _same_label(a.alternative, b.alternative, tol)


def _situations(cfg, layout_name, count, seed, shapes=None):
    """``count`` sampled situations (only those the fitted labeller solves on one of ``shapes``)."""
    from casadi_gpc.problem.selection import select_obstacles
    rng, out = np.random.default_rng(seed), []
    while len(out) < count:
        sit = sample_situation(rng, cfg, layout_name)
        sel = select_obstacles(sit.robot.as_array(), sit.forecasts(), sit.statics, cfg)
        if shapes is None or fitted_slots(len(sel.forecasts), len(sel.statics), cfg) in shapes:
            out.append(sit)
    return out


def test_fitted_slots_rounds_up_to_a_rung_and_caps_at_the_config():
    imp, pap = preset("improved"), preset("paper")   # 10 + 3 and 3 + 3 slots
    assert (imp.max_moving, imp.max_static, pap.max_moving, pap.max_static) == (10, 3, 3, 3)
    assert fitted_slots(0, 0, imp) == fitted_slots(1, 0, imp) == (1, 0)
    assert fitted_slots(2, 1, imp) == (2, 1) and fitted_slots(3, 2, imp) == (4, 3)
    assert fitted_slots(5, 0, imp) == fitted_slots(6, 0, imp) == (6, 0)
    assert fitted_slots(7, 0, imp) == (10, 0) and fitted_slots(10, 1, imp) == (10, 1)
    assert fitted_slots(10, 3, imp) == (10, 3) and fitted_slots(3, 3, pap) == fitted_slots(3, 2, pap) == (3, 3)
    with pytest.raises(ValueError):
        fitted_slots(11, 0, imp)


def test_fitted_nlp_labels_are_the_full_nlp_s():
    """The labeller selects the obstacles with the planner's slots and solves on the smallest
    NLP that holds them: the labels are the full NLP's (to 1e-12; measured bit for bit), on
    30 ``paper``-layout situations (one mover at most: the 1 + 0 NLP) and 10 ``multi`` ones
    with three movers and two or three static obstacles (the 4 + 3 NLP)."""
    cfg = preset("improved")
    fit, full = Labeller(cfg), Labeller(cfg, fit_slots=False)
    paper = _situations(cfg, "paper", 30, 11)
    multi = _situations(cfg, "multi", 10, 12, shapes={(4, 3)})
    for sit in paper + multi:
        _same_label(fit.label(sit), full.label(sit))
    assert full.counters["full_nlp"] == 40 and full.counters["fitted_nlp"] == 0
    assert fit.counters["full_nlp"] == 0 and fit.counters["fitted_nlp"] == 40
    assert fit.counters["nlp_1x0"] == 30 and fit.counters["nlp_4x3"] == 10
    # the public parameter vector stays the full NLP's
    np.testing.assert_array_equal(fit.parameters(multi[0]), full.parameters(multi[0]))
    assert fit.parameters(multi[0]).size == full.controller.problem.layout.size


def test_fitted_nlp_near_tie_and_fallback_paths_match_the_full_nlp():
    """The near-tie rule (roll-outs of the fitted NLP's plans on its own parameters) and the
    fallback solver (on the fitted NLP too) give the full NLP's labels."""
    cfg = preset("improved")
    sits = _situations(cfg, "paper", 8, 13, shapes={(1, 0)})
    fit, full = Labeller(cfg, tie_margin=0.05), Labeller(cfg, tie_margin=0.05, fit_slots=False)
    for sit in sits:
        _same_label(fit.label(sit), full.label(sit))
    assert fit.counters["nlp_1x0"] == 8 and full.counters["full_nlp"] == 8
    # the labelling solver finds nothing: the fallback solver answers, on the same NLP
    fit, full = Labeller(cfg), Labeller(cfg, fit_slots=False)
    for ctl in (fit.prepare(1, 0), full.prepare()):
        ctl.plan = lambda *args: (None, [])
    for sit in sits[:3]:
        a, b = fit.label(sit), full.label(sit)
        assert a.converged and a.solver == FALLBACK_SOLVER
        _same_label(a, b)
    assert fit.counters["fallback_converged"] == 3 and fit.counters["nlp_1x0"] == 3
    assert (FALLBACK_SOLVER, 1, 0) in fit._controllers and (FALLBACK_SOLVER, *fit.full_slots) not in fit._controllers


def test_a_selection_that_needs_every_slot_is_solved_on_the_full_nlp():
    """Under ``paper`` (3 + 3 slots) a situation with three movers and static obstacles
    rounds up to the full NLP: the fitted labeller uses it (counted) and says the same."""
    cfg = preset("paper")
    sits = _situations(cfg, "multi", 3, 14, shapes={(3, 3)})
    fit, full = Labeller(cfg), Labeller(cfg, fit_slots=False)
    for sit in sits:
        _same_label(fit.label(sit), full.label(sit))
    assert fit.counters["full_nlp"] == 3 and fit.counters["fitted_nlp"] == 0

