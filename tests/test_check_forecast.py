"""What the deployed policy hands its check layer: the tracks forecast as the preset's planner
forecasts them (straight on in ``improved``: casadi_gpc.estimation.obstacle_model.straightened), while the
network's own features keep the turning forecast it was trained with."""
from __future__ import annotations

import numpy as np
import pytest

from casadi_gpc.estimation.ekf import ObstacleEKF
from casadi_gpc.estimation.ekf_batch import MANY_TRACKS, ForecastBatch
from casadi_gpc.safety.check import forecast_arrays, shared_batch
from casadi_gpc.types import ObstacleMeasurement
from nn_export.runtime.policy import OnnxPolicy
from nn_export.runtime.situation import straight_estimates, track_estimates
from scenarios import Suite
from scenarios.simulator import simulate


def _turning_filters(n: int, T: float = 0.5, seen_once=()) -> list[ObstacleEKF]:
    """``n`` filters fed walkers on arcs (so that the estimated turn increment is not zero),
    the indices in ``seen_once`` having seen a single position."""
    rng = np.random.default_rng(3)
    out = []
    for i in range(n):
        ekf = ObstacleEKF(T)
        x, y, th, v, w = *rng.normal(0, 4, 2), rng.uniform(-3, 3), rng.uniform(0.3, 1.5), rng.uniform(-0.4, 0.4)
        for _ in range(1 if i in seen_once else 8):
            ekf.step((x + rng.normal(0, 0.02), y + rng.normal(0, 0.02)))
            th += w * T
            x, y = x + v * T * np.cos(th), y + v * T * np.sin(th)
        out.append(ekf)
    return out


def _close(a, b):
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * (1 + np.abs(b).max()))


@pytest.mark.parametrize("n", [3, MANY_TRACKS + 4])
def test_straight_estimates_are_each_filters_straight_forecast(n):
    """Below and above the batch size, one track seen once among them: each handed estimate's
    forecast is the filter's own ``predict(straight=True)`` (a track seen once stands where it
    was seen either way); identity, radius, state and the turning estimates are untouched."""
    filters = _turning_filters(n, seen_once=(1,))
    pairs = [(ObstacleMeasurement(10 + i, (0.0, 0.0), 0.25 + 0.01 * i), f) for i, f in enumerate(filters)]
    turning = track_estimates(pairs, 12)
    straight = straight_estimates(turning)
    differs = 0
    for t, s, (m, f) in zip(turning, straight, pairs):
        assert (s.obstacle_id, s.radius_m, s.initialised, s.state_values) == (t.obstacle_id, t.radius_m,
                                                                               t.initialised, t.state_values)
        means, covs = f.predict(12, straight=True)
        _close(s.means_m, means)
        _close(s.covs_m2, covs)
        tm, tc = f.predict(12)
        _close(t.means_m, tm)  # the turning ones are still the turning forecast
        differs += not np.allclose(tm, means)
    assert differs == n - 1  # every track that has seen two positions turns, and is handed straight
    if n >= MANY_TRACKS:  # a crowd's: one straightened batch, taken whole by the check
        batch = shared_batch(straight)
        assert isinstance(batch, ForecastBatch) and batch.straight and batch is not shared_batch(turning)
        m, c, w = forecast_arrays(straight)
        assert m is batch.arrays[0] and c is batch.planning_covs and w is batch.worst_std_m
    else:
        assert shared_batch(straight) is None


def test_the_straight_forecast_is_narrower_for_a_walker_seen_briefly():
    """The reason for handing the check the straight forecast: a walker at 1.3 m/s seen for
    1.5 s, whose turn the filter barely knows, is metres wide at 6 s on the turning forecast."""
    ekf = ObstacleEKF(0.5)
    rng = np.random.default_rng(0)
    for k in range(4):
        ekf.step((1.3 * 0.5 * k + rng.normal(0, 0.02), rng.normal(0, 0.02)))
    worst = [np.sqrt(np.linalg.eigvalsh(ekf.predict(12, straight=s)[1][-1])[-1]) for s in (False, True)]
    assert worst[0] > 1.5 and worst[1] < 0.5, worst


def test_the_policy_hands_the_presets_forecast_and_decides_as_before():
    """``improved`` hands its check the straight forecast by default, ``paper`` the turning one
    (their planners'); the network's commands do not depend on it (its features read the
    turning forecast), step for step along a closed-loop crowd crossing."""
    assert OnnxPolicy(preset="improved").check_forecast == "straight"
    assert OnnxPolicy(preset="paper").check_forecast == "turn"
    with pytest.raises(ValueError, match="check_forecast must be"):
        OnnxPolicy(preset="improved", check_forecast="wiggly")
    sc = Suite("circle-crossing", 1, 1, 10, "orca").scenario(0)
    seen = []

    class _Recorder:
        def __init__(self, policy):
            self.policy, self.sample_time_s, self.counters = policy, policy.sample_time_s, {}

        def reset(self):
            self.policy.reset()

        def decide(self, obs):
            seen.append(obs)
            return self.policy.decide(obs)

    straight_policy = OnnxPolicy(preset="improved")
    simulate(sc, _Recorder(straight_policy), "nn")
    assert straight_policy.model_info["check_forecast"] == "straight"
    straight_policy.reset()
    turning_policy = OnnxPolicy(preset="improved", check_forecast="turn")
    crowded = 0
    for obs in seen:
        a, b = straight_policy.decide(obs), turning_policy.decide(obs)
        assert (a.v_right_mps, a.v_left_mps) == (b.v_right_mps, b.v_left_mps)
        ra, rb = straight_policy.rollout(), turning_policy.rollout()  # the network's own plan: the same
        assert (ra is None) == (rb is None) and (ra is None or all(np.array_equal(x, y) for x, y in zip(ra, rb)))
        assert [f.obstacle_id for f in a.forecasts] == [f.obstacle_id for f in b.forecasts]
        for fa, fb in zip(a.forecasts, b.forecasts):
            snap = fb._filter  # the turning estimate's filter state: its straight forecast is what a got
            means, covs = snap.predict(12, straight=True)
            _close(fa.means_m, means)
            _close(fa.covs_m2, covs)
        crowded += len(a.forecasts) >= MANY_TRACKS
    assert len(seen) > 20 and crowded > 10
