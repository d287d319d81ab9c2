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
    seen = np.array(log.obstacle_xy)[:, :len(sc.moving)]
    assert len(seen) > 10 and truth.shape[1:] == seen.shape[1:]
    np.testing.assert_array_equal(truth[:len(seen)], seen)


def test_walkers_that_see_the_robot_have_no_oracle():
    sc = Suite("circle-crossing", 1, 1, 3, "orca").scenario(0)
    seeing = dataclasses.replace(sc, moving=tuple(dataclasses.replace(m, sees_robot=True) for m in sc.moving))
    with pytest.raises(SystemExit, match="see the robot"):
        oracle.true_positions(seeing, T, 12)
