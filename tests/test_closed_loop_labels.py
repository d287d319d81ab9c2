"""Closed-loop labels (nn_export/training/dataset/onpolicy.py): a situation visited in an
episode is labelled by a GPC kept in step with the episode, so where the GPC itself drives
(bare, no noise) the labels are its own commands, exactly; cold labels of the same situations
are the fixed-guess multi-start's, which need not be."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("casadi")

from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.planner.gpc import GPCController  # noqa: E402
from casadi_gpc.robot import RobotParams  # noqa: E402
from nn_export.runtime.layouts import layout_for  # noqa: E402
from nn_export.training.dataset import OnPolicyOptions, collect_on_policy  # noqa: E402
from scenarios import load_scenario  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402

CFG = preset("improved")


class _Logged:
    """The bare GPC, its commands kept."""

    def __init__(self):
        self.gpc = GPCController(CFG, RobotParams())
        self.sample_time_s = self.gpc.sample_time_s
        self.commands = []

    def reset(self):
        self.gpc.reset()
        self.commands = []

    def decide(self, obs):
        d = self.gpc.decide(obs)
        self.commands.append((d.v_right_mps, d.v_left_mps, d.fallback))
        return d


def test_closed_loop_labels_are_the_driving_gpcs_own_commands():
    sc = load_scenario("scenarios/paper/fig7_2_crossing.toml")
    driver = _Logged()
    log = simulate(sc, driver, "gpc")
    commands = driver.commands
    layout = layout_for("set", CFG.horizon)
    options = OnPolicyOptions(CFG, layout, robot=RobotParams(), mirror=True, labels="closed-loop")
    arrays, stats = collect_on_policy(driver, [sc], options)
    own = ~arrays["mirror"]
    driven = np.array([(vr, vl) for vr, vl, fell in commands if not fell])
    assert stats["episodes"][0]["outcome"] == log.outcome and len(driven) == own.sum()
    assert np.array_equal(arrays["labels"][own], driven)  # the same commands, bit for bit
    assert set(arrays["status"][own]) == {"closed-loop"} and np.isnan(arrays["mirror_check_mps"]).all()
    # the mirror sample of each: the mirrored features, the wheels swapped
    assert np.array_equal(arrays["labels"][~own], driven[:, ::-1])
    # cold labels of the very same situations: a multi-start from the fixed guesses
    cold, _ = collect_on_policy(driver, [sc], OnPolicyOptions(CFG, layout, robot=RobotParams(), mirror=False))
    assert np.array_equal(cold["features"], arrays["features"][own])
    assert set(cold["status"]) != {"closed-loop"}


def test_closed_loop_labels_are_refused_with_a_tie_margin_and_unknown_kinds():
    layout = layout_for("set", CFG.horizon)
    with pytest.raises(ValueError, match="tie margin"):
        OnPolicyOptions(CFG, layout, labels="closed-loop", tie_margin=0.01)
    with pytest.raises(ValueError, match="labels must be one of"):
        OnPolicyOptions(CFG, layout, labels="warm")
