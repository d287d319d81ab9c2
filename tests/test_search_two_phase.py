"""The check's two-phase way out (``CheckSettings(search_two_phase=True)``,
:meth:`casadi_gpc.safety.search.WayOutSearch._two_phase`): where no searched sequence keeps
the margin, the best of them continued with a second target. Checked against an independent
reading of what it must return: the same answer as the one-phase search wherever a single
sequence is safe; otherwise a sequence whose first phase is one of the best single ones, that
is safe or better than the best single one by the check's order, or the single one itself;
the wheels within the robot's limits; its check the sequence's own, measured afresh."""
from __future__ import annotations

import numpy as np
import pytest

from casadi_gpc.robot import RobotParams
from casadi_gpc.safety import CheckSettings, SafetyFilter
from casadi_gpc.safety.search import TWO_PHASE_BASES, TWO_PHASE_SWITCH_S
from casadi_gpc.types import ObstacleForecast, StaticObstacle

ROBOT = RobotParams()
H, T = 12, 0.5


def _crowd(rng, n: int, spread: float):
    out = []
    for i in range(n):
        start, vel = rng.uniform(-spread, spread, 2), rng.uniform(-0.8, 0.8, 2)
        means = start + np.arange(1, H + 1)[:, None] * T * vel
        a = rng.uniform(1e-4, 0.02) * np.arange(1, H + 1)
        covs = np.zeros((H, 2, 2))
        covs[:, 0, 0] = covs[:, 1, 1] = a
        out.append(ObstacleForecast(i, rng.uniform(0.2, 0.35), means, covs))
    return out, (StaticObstacle((rng.uniform(-3, 3), rng.uniform(-3, 3)), 0.3),)


def test_two_phase_search_needs_the_search():
    with pytest.raises(ValueError, match="search_two_phase needs search"):
        CheckSettings(search_two_phase=True)
    assert CheckSettings(search=True, search_two_phase=True).search_two_phase


def test_two_phase_search_against_the_one_phase_search():
    one, two = SafetyFilter(ROBOT, T, H, search=True), SafetyFilter(ROBOT, T, H, search=True, search_two_phase=True)
    rng = np.random.default_rng(7)
    vmax, N = ROBOT.max_wheel_speed_mps, H * one.substeps
    switch_steps = [int(round(t / T)) for t in TWO_PHASE_SWITCH_S]
    stats = {"safe": 0, "none_safe": 0, "taken": 0, "taken_safe": 0}
    for _ in range(150):
        forecasts, statics = _crowd(rng, int(rng.integers(8, 20)), float(rng.choice([1.2, 2.0, 3.0])))
        state = np.array([0.0, 0.0, rng.uniform(-3, 3), *rng.uniform(-vmax, vmax, 2)])
        wish = np.clip(state[3:5] + rng.uniform(-0.2, 0.2, 2), -vmax, vmax)
        obstacles = one.obstacle_tracks(forecasts, statics)
        taken_before = two.counters["two_phase_taken"]
        n1, w1, c1 = one.search(state, obstacles, wish)
        n2, w2, c2 = two.search(state, obstacles, wish)
        if c1.safe:  # a single sequence keeps the margin: the same answer to the bit
            stats["safe"] += 1
            assert (n1, w1.tobytes(), c1) == (n2, w2.tobytes(), c2)
            continue
        stats["none_safe"] += 1
        if two.counters["two_phase_taken"] == taken_before:  # nothing better: the single one stands
            assert (n1, w1.tobytes(), c1) == (n2, w2.tobytes(), c2)
            continue
        stats["taken"] += 1
        stats["taken_safe"] += c2.safe
        assert c2.safe or one._better(c2, c1)
        # its first phase is one of the best single sequences, as the robot would drive it
        assert " then search(" in n2
        base, _, rest = n2.partition(" then ")
        s = int(round(float(rest.rsplit("+", 1)[1].split()[0]) / T))
        assert s in switch_steps
        v0 = state[3:5]
        singles = np.concatenate([one._searched(v0, H), one.manoeuvres(v0)[1]])
        k = one._search_names.index(base)
        np.testing.assert_array_equal(w2[:s], singles[k, :s])
        # and its check is the sequence's own, measured afresh
        again = one.clearances(state, w2[None], obstacles)
        assert bool(again[4][0] == N) == c2.safe and again[0][0] == c2.min_clearance_m
        # the wheels keep the limits: the second target approached at the acceleration limit
        dv = ROBOT.max_step_change_mps(T)
        assert np.abs(w2).max() <= vmax + 1e-9 and np.abs(np.diff(w2, axis=0)).max() <= dv + 1e-9
    assert two.counters["two_phase_searched"] == stats["none_safe"]
    assert two.counters["two_phase_taken"] == stats["taken"]
    assert two.counters["two_phase_safe"] == stats["taken_safe"]
    print(stats)
    assert stats["safe"] and stats["none_safe"] and stats["taken_safe"]  # every branch was exercised
    assert TWO_PHASE_BASES >= 1
