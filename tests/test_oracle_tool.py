"""tools/oracle_forecasts.py: the walkers' true futures it hands the planner are the
simulator's positions, bit for bit, whatever the robot does (walkers blind to the robot)."""
from __future__ import annotations

import dataclasses
import importlib.util
from pathlib import Path

import numpy as np
import pytest

from scenarios.simulator import simulate
from casadi_gpc.types import ControlDecision
from scenarios import Suite

_spec = importlib.util.spec_from_file_location("oracle_forecasts",
                                               Path(__file__).resolve().parents[1] / "tools" / "oracle_forecasts.py")
oracle = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(oracle)

T = 0.5


class _Wheels:
    """Drives fixed wheel speeds (a robot the walkers do not see anyway)."""

    sample_time_s, horizon = T, 12

    def __init__(self, vr, vl):
        self.vr, self.vl = vr, vl

    def reset(self):
        pass

    def decide(self, obs):
        return ControlDecision(self.vr, self.vl)


@pytest.mark.parametrize("wheels", [(0.0, 0.0), (0.5, 0.3)])
def test_the_true_futures_are_the_simulator_s_positions(wheels):
    sc = Suite("circle-crossing", 1, 1, 10, "orca").scenario(109)
    truth = oracle.true_positions(sc, T, 12)
    log = simulate(sc, _Wheels(*wheels), "wheels")
    # the records at the sample instants (a collided run's last one is at the contact)
    at_samples = [k for k, t in enumerate(log.t) if abs(t / T - round(t / T)) < 1e-9]
    seen = np.array(log.obstacle_xy)[at_samples, :len(sc.moving)]
    assert len(seen) > 10 and truth.shape[1:] == seen.shape[1:]
    np.testing.assert_array_equal(truth[:len(seen)], seen)


def test_walkers_that_see_the_robot_have_no_oracle():
    sc = Suite("circle-crossing", 1, 1, 3, "orca").scenario(0)
    seeing = dataclasses.replace(sc, moving=tuple(dataclasses.replace(m, sees_robot=True) for m in sc.moving))
    with pytest.raises(SystemExit, match="see the robot"):
        oracle.true_positions(seeing, T, 12)


@pytest.mark.parametrize("suite, enters_and_leaves", [("corridor", False), ("doorway", True)])
def test_walkers_among_walls_that_enter_and_leave_are_the_simulator_s_too(suite, enters_and_leaves):
    """The wall suites' walkers follow tracks: they enter and leave the scene (the simulator
    gives NaN outside), and they avoid the walls. The true futures take the walls and hold an
    absent walker where it enters or leaves, where the simulator has NaN (in the doorway
    episode, whose standing robot is not hit before some walkers have left; in the corridor's
    it is hit first)."""
    sc = Suite(suite, 74, 1, 5).scenario(73)
    truth = oracle.true_positions(sc, T, 12)
    log = simulate(sc, _Wheels(0.0, 0.0), "wheels")
    at_samples = [k for k, t in enumerate(log.t) if abs(t / T - round(t / T)) < 1e-9]  # (not the contact's)
    seen = np.array(log.obstacle_xy, dtype=float)[at_samples, :len(sc.moving)]
    gone = ~np.isfinite(seen)
    assert gone.any() == enters_and_leaves and np.isfinite(truth).all()
    np.testing.assert_array_equal(truth[:len(seen)][~gone], seen[~gone])
    raw = oracle.true_positions(sc, T, 12, hold_absent=False)  # NaN where absent, as the simulator
    np.testing.assert_array_equal(raw[:len(seen)], seen)
    for j in range(truth.shape[1]):  # held where it enters and where it leaves
        here = np.flatnonzero(~gone[:, j, 0])
        np.testing.assert_array_equal(truth[:here[0], j], np.broadcast_to(seen[here[0], j], (here[0], 2)))
        if here[-1] + 1 < len(seen):  # it left within the episode
            after = truth[here[-1] + 1:, j]
            np.testing.assert_array_equal(after, np.broadcast_to(seen[here[-1], j], after.shape))


class _Forecasts:
    """Stands for the planner's own estimate: one forecast per walker, a covariance of its own."""

    def __init__(self, ids):
        self.ids = ids

    def __call__(self, obs):
        from casadi_gpc.types import ObstacleForecast
        return [ObstacleForecast(j, 0.3, np.zeros((12, 2)), np.full((12, 2, 2), 0.01 * (j + 1))) for j in self.ids]


@pytest.mark.parametrize("present, std", [(False, 0.05), (False, None), (True, 0.05)])
def test_the_oracle_s_forecasts_are_the_truth_or_the_present_carried_on(present, std, monkeypatch):
    """``--forecast truth``: the true positions at steps 1..H with the given deviation (``--std
    filter``, None: the planner's own covariances); ``--forecast present``: the true position
    now plus k times the last interval's true displacement at step k, with the planner's own
    covariances; only the walkers it tracks."""
    from casadi_gpc.config import preset
    from casadi_gpc.planner.gpc import GPCController
    rng = np.random.default_rng(3)
    truth = rng.normal(0.0, 3.0, (30, 4, 2))
    monkeypatch.setattr(GPCController, "estimate", lambda self, obs: _Forecasts([0, 2])(obs))
    gpc = object.__new__(oracle.OracleGPC)  # no NLP: only the forecasts are under test
    gpc.config = preset("improved")
    gpc.use_truth(truth, [0.3] * 4, std, present_only=present)

    class _Obs:
        t_s = 7 * T
    got = gpc.estimate(_Obs())
    assert [f.obstacle_id for f in got] == [0, 2]
    for f in got:
        j = f.obstacle_id
        if present:
            want = truth[7, j] + np.arange(1, 13)[:, None] * (truth[7, j] - truth[6, j])
            np.testing.assert_allclose(f.means_m, want, rtol=0, atol=1e-12)
            np.testing.assert_array_equal(f.covs_m2, np.full((12, 2, 2), 0.01 * (j + 1)))
        else:
            np.testing.assert_array_equal(f.means_m, truth[8:20, j])
            want = np.full((12, 2, 2), 0.01 * (j + 1)) if std is None else np.tile(np.eye(2) * std ** 2, (12, 1, 1))
            np.testing.assert_allclose(f.covs_m2, want, rtol=0, atol=0)


@pytest.mark.parametrize("argv", [["--std", "abc"], ["--std", "0"], ["--episodes", "3-1"], ["--episodes", "x"],
                                  ["--slots", "0"], ["--forecast", "future"]])
def test_bad_arguments_are_refused_in_one_line(argv, capsys):
    with pytest.raises(SystemExit) as e:
        oracle.main(argv)
    assert e.value.code == 2
    assert ": error: " in capsys.readouterr().err.strip().splitlines()[-1]
