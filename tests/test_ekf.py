"""The obstacle EKF (casadi_gpc.estimation.ekf): convergence, predicted covariance against Monte Carlo,
missing measurements and outliers."""
from __future__ import annotations

import math

import numpy as np
import pytest

from casadi_gpc.config import PRESETS
from casadi_gpc.estimation.ekf import EKFSettings, ObstacleEKF
from casadi_gpc.estimation.obstacle_model import _jacobian, obstacle_model_step, planning_covariances
from casadi_gpc.robot import RobotState
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.types import ObstacleMeasurement, Observation
from scenarios.model import MovingObstacleSpec

SPEED, TURN = 0.4, 0.15  # m/s, rad/s
OBSTACLE = MovingObstacleSpec((2.0, -1.0), 0.3, SPEED, 0.3, TURN)
SAMPLE_TIMES = sorted({c.sample_time_s for c in PRESETS.values()})


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def run_filter(T: float, steps: int, noise: float, seed: int, settings: EKFSettings | None = None) -> ObstacleEKF:
    """Track OBSTACLE (an exact arc) from ``steps`` noisy position measurements."""
    rng = np.random.default_rng(seed)
    ekf = ObstacleEKF(T, settings or EKFSettings(measurement_std_m=max(noise, 1e-3)))
    for k in range(steps):
        x, y, _ = OBSTACLE.state_at(k * T)
        ekf.step(np.array([x, y]) + rng.normal(0.0, noise, 2))
    return ekf


def truth(T: float, k: int) -> np.ndarray:
    """The model state of OBSTACLE at sample k. Sampled every T s, an arc has constant chord
    length V T sinc(w T / 2) and chord heading (heading at mid-interval) turning w T a step."""
    x, y, h = OBSTACLE.state_at(k * T)
    chord_speed = SPEED * np.sinc(TURN * T / 2 / np.pi)
    return np.array([x, y, chord_speed, h - TURN * T / 2, TURN * T])


@pytest.mark.parametrize("T", SAMPLE_TIMES)
def test_converges_exactly_without_noise(T):
    """An exact arc fits the model exactly: the estimate goes to the true chord speed and
    heading increment."""
    ekf = run_filter(T, int(40 / T), noise=0.0, seed=0)
    want = truth(T, int(40 / T) - 1)
    s = ekf.state_
    assert np.hypot(*(s[:2] - want[:2])) < 2e-3
    assert s[2] == pytest.approx(want[2], abs=2e-3)
    assert wrap(s[3] - want[3]) == pytest.approx(0.0, abs=2e-3)
    assert s[4] == pytest.approx(want[4], abs=1e-3)


@pytest.mark.parametrize("T", SAMPLE_TIMES)
@pytest.mark.parametrize("seed", range(4))
def test_converges_on_a_turning_obstacle_with_noise(T, seed):
    n = int(30 / T)
    ekf = run_filter(T, n, noise=0.02, seed=seed)
    want = truth(T, n - 1)
    s, sd = ekf.state_, np.sqrt(np.diag(ekf.cov_))
    err = np.array([s[0] - want[0], s[1] - want[1], s[2] - want[2], wrap(s[3] - want[3]), s[4] - want[4]])
    # close to the truth in absolute terms ...
    assert np.hypot(err[0], err[1]) < 0.06
    assert abs(err[2]) < 0.05  # m/s
    assert abs(err[4]) < 0.2 * TURN * T + 0.01  # rad per step
    # ... and consistent with the filter's own uncertainty
    assert np.all(np.abs(err) < 4.0 * sd), (err, sd)
    # the young track (after two measurements) knew nothing of the turn
    young = run_filter(T, 2, noise=0.02, seed=seed)
    assert young.state_[4] == 0.0
    assert abs(err[4]) < 0.5 * TURN * T


@pytest.mark.parametrize("name", sorted(PRESETS))
def test_predicted_covariance_matches_monte_carlo(name):
    """Sample the EKF's Gaussian, propagate with the same model and process noise Q; the
    spread of the positions at steps 1..H matches the predicted covariances within 20 %."""
    cfg = PRESETS[name]
    T, H = cfg.sample_time_s, cfg.horizon
    ekf = run_filter(T, int(20 / T), noise=0.02, seed=11)
    st = ekf.settings
    Q = ekf._Q()
    np.testing.assert_allclose(np.diag(Q), [st.position_noise_m ** 2, st.position_noise_m ** 2,
                                            (st.speed_noise_mps2 * T) ** 2, st.heading_noise_rad ** 2,
                                            st.turn_noise_rad ** 2])
    means, covs = ekf.predict(H)
    assert means.shape == (H, 2) and covs.shape == (H, 2, 2)
    rng = np.random.default_rng(5)
    n = 40000
    s = rng.multivariate_normal(ekf.state_, ekf.cov_, n)
    for j in range(H):
        s = obstacle_model_step(s, T) + rng.multivariate_normal(np.zeros(5), Q, n)
        c = np.cov(s[:, :2].T)
        rel = np.linalg.norm(c - covs[j]) / np.linalg.norm(covs[j])
        assert rel < 0.2, (j, rel)
        assert np.trace(c) / np.trace(covs[j]) == pytest.approx(1.0, abs=0.2)
        # the mean follows the noise-free prediction (to a fraction of the spread)
        assert np.hypot(*(s[:, :2].mean(axis=0) - means[j])) < 0.5 * math.sqrt(np.trace(covs[j]))
    # and the covariance grows along the horizon
    assert np.all(np.diff(np.trace(covs, axis1=1, axis2=2)) > 0)


@pytest.mark.parametrize("missing", [None, [float("nan"), 1.0], (float("inf"), 0.0)])
def test_missing_measurement_skips_the_update_and_grows_the_covariance(missing):
    T = 0.5
    ekf = run_filter(T, 20, noise=0.02, seed=1)
    before_s, before_p = ekf.state_.copy(), ekf.cov_.copy()
    assert ekf.step(missing) == "missed"
    assert ekf.missed_ == 1
    # the state is the model's prediction, untouched by any measurement
    np.testing.assert_allclose(ekf.state_, obstacle_model_step(before_s, T), atol=1e-15)
    assert np.trace(ekf.cov_[:2, :2]) > np.trace(before_p[:2, :2])
    grown = np.trace(ekf.cov_[:2, :2])
    assert ekf.step(None) == "missed"
    assert ekf.missed_ == 2
    assert np.trace(ekf.cov_[:2, :2]) > grown
    # a good measurement again: the update shrinks it
    x, y, _ = OBSTACLE.state_at(21 * T)
    assert ekf.step([x, y]) == "update"
    assert np.trace(ekf.cov_[:2, :2]) < grown


def test_missing_before_the_track_starts_is_counted():
    ekf = ObstacleEKF(0.5)
    assert ekf.step(None) == "missed"
    assert ekf.state_ is None and ekf.missed_ == 1
    assert ekf.step([1.0, 2.0]) == "start"
    p1 = np.trace(ekf.cov_[:2, :2])
    assert ekf.step([float("nan"), 2.0]) == "missed"
    assert ekf.missed_ == 2
    assert np.trace(ekf.cov_[:2, :2]) > p1
    assert ekf.step([1.1, 2.0]) == "update"
    assert ekf.initialised
    with pytest.raises(RuntimeError):
        ObstacleEKF(0.5).predict(3)


@pytest.mark.parametrize("gap", [1, 2, 4])
def test_missed_samples_between_the_first_two_measurements(gap):
    """The first speed estimate divides by the real time between the two measurements
    (it used to divide by one sample time, doubling the speed after one dropout)."""
    T = 0.5
    ekf = ObstacleEKF(T)
    ekf.step([1.0, 1.0])
    for _ in range(gap - 1):
        assert ekf.step(None) == "missed"
    assert ekf.step([1.0 + 0.3 * gap * T, 1.0 + 0.4 * gap * T]) == "update"
    assert ekf.state_[2] == pytest.approx(0.5, rel=1e-12)
    assert ekf.state_[3] == pytest.approx(math.atan2(0.4, 0.3), rel=1e-12)
    assert ekf.missed_ == gap - 1
    # and it then tracks the straight motion exactly
    for k in range(gap + 1, gap + 6):
        ekf.step([1.0 + 0.3 * k * T, 1.0 + 0.4 * k * T])
    assert ekf.state_[2] == pytest.approx(0.5, abs=1e-3)


def test_a_glitch_is_gated_and_changes_nothing():
    """A measurement 3 m off (6 m/s of velocity change in 0.5 s) is not fused, the prediction
    and its covariance untouched; its ghost stands there for the one sample that decides (a
    glitch, or someone there: planned around either way); the next good one is fused and the
    ghost is gone."""
    T = 0.5
    ekf = run_filter(T, 20, noise=0.02, seed=2)
    s0, p0 = ekf.state_.copy(), ekf.cov_.copy()
    x, y, _ = OBSTACLE.state_at(20 * T)
    _, p_pred = _matrix_step(ekf, s0, p0, None)  # the propagated covariance, independently
    assert ekf.step([x + 3.0, y]) == "outlier"
    assert ekf.outliers_ == 1
    np.testing.assert_allclose(ekf.ghost().state_[:3], [x + 3.0, y, 0.0], atol=1e-15)
    np.testing.assert_allclose(ekf.state_, obstacle_model_step(s0, T), atol=1e-15)  # no update
    np.testing.assert_allclose(ekf.cov_, p_pred, rtol=1e-12, atol=1e-15)
    x, y, _ = OBSTACLE.state_at(21 * T)
    assert ekf.step([x, y]) == "update" and ekf.ghost() is None and ekf.maneuvers_ == 0


def test_an_id_that_comes_to_name_someone_elsewhere_is_followed_from_the_second_sample():
    """A tracker reuses an id: the walker it named walked along x at 0.5 m/s; from one sample on
    it names a person 3 m away walking along y at 0.6 m/s. The first measurement there is gated
    (far beyond any manoeuvre) and its ghost stands there at once; the second agrees with it:
    the track follows the new person, its velocity from the two. Until 2026-12-02 the first was
    a glitch with no ghost, and the person was unseen, the track forecast where the old walker
    would have been, until the third rejection restarted it."""
    T = 0.5
    ekf = ObstacleEKF(T)
    for k in range(12):
        ekf.step([0.5 * k * T, 0.0])
    other = [(2.0, 3.0 + 0.6 * k * T) for k in range(3)]
    assert ekf.step(other[0]) == "outlier"
    np.testing.assert_allclose(ekf.ghost().state_[:2], other[0], atol=1e-15)
    assert ekf.step(other[1]) == "manoeuvre" and ekf.ghost() is None
    means, _ = ekf.predict(2)
    np.testing.assert_allclose(means, [(2.0, 3.0 + 0.6 * 2 * T), (2.0, 3.0 + 0.6 * 3 * T)], atol=1e-9)
    assert ekf.step(other[2]) == "update"


def test_a_plausible_rejection_leaves_a_ghost_until_the_next_sample_decides():
    """0.3 m off (0.6 m/s of velocity change, within max_maneuver_mps): not fused, but kept
    pending, and the ghost filter stands there; the next measurement back on the track is
    fused (a glitch after all) and the ghost is gone."""
    T = 0.5
    ekf = run_filter(T, 20, noise=0.02, seed=2)
    s0 = ekf.state_.copy()
    predicted = obstacle_model_step(s0, T)
    z = predicted[:2] + np.array([0.18, -0.24])
    assert ekf.step(z) == "outlier"
    np.testing.assert_allclose(ekf.state_, predicted, atol=1e-15)
    g = ekf.ghost()
    np.testing.assert_allclose(g.state_[:3], [z[0], z[1], 0.0], atol=1e-15)  # standing there
    means, _ = g.predict(4)
    np.testing.assert_allclose(means, np.tile(z, (4, 1)), atol=1e-12)
    x, y, _ = OBSTACLE.state_at(21 * T)
    assert ekf.step([x, y]) == "update" and ekf.ghost() is None


def test_an_obstacle_that_stops_dead_is_a_ghost_then_a_manoeuvre():
    """A walker at 0.5 m/s stops at its goal: the first measurement of it standing is gated
    (0.25 m from the prediction) and its ghost stands there; the second agrees with the
    first: a manoeuvre, the velocity estimated afresh from the two (0)."""
    T = 0.5
    ekf = ObstacleEKF(T)
    for k in range(12):
        ekf.step([0.5 * k * T, 0.0])
    stop = (0.5 * 11 * T, 0.0)
    assert ekf.step(stop) == "outlier"
    np.testing.assert_allclose(ekf.ghost().state_[:3], [stop[0], stop[1], 0.0], atol=1e-15)
    assert ekf.step(stop) == "manoeuvre" and ekf.maneuvers_ == 1
    np.testing.assert_allclose(ekf.state_[:3], [stop[0], stop[1], 0.0], atol=1e-12)
    assert ekf.ghost() is None


def test_a_person_who_sets_off_from_standing_is_a_manoeuvre_at_the_second_sample():
    """A person standing for 10 s sets off at 0.8 m/s. Their first measurement walking is gated
    (0.4 m from the prediction: a ghost there); the second, 0.4 m further on, agrees with the
    first: a manoeuvre, the velocity estimated from the two, though it is 0.8 m from the
    standing prediction (beyond 0.75 m). Before 2026-11-29 it was judged by that prediction, a
    glitch with no ghost, and the person was forecast standing where they had been until the
    third rejection restarted the track (a collision in ``corridor``, seed 1, episode 172)."""
    T, speed = 0.5, 0.8
    ekf = ObstacleEKF(T)
    for _ in range(20):
        ekf.step([9.0, -0.5])
    first, second = (9.0 - speed * T, -0.5), (9.0 - 2 * speed * T, -0.5)
    assert ekf.step(first) == "outlier"
    np.testing.assert_allclose(ekf.ghost().state_[:2], first, atol=1e-15)
    assert ekf.step(second) == "manoeuvre" and ekf.maneuvers_ == 1
    means, _ = ekf.predict(2)
    np.testing.assert_allclose(means, [(9.0 - 3 * speed * T, -0.5), (9.0 - 4 * speed * T, -0.5)], atol=1e-9)
    # a lone glitch as far off is still no manoeuvre: the next measurement back in place is fused
    ekf = ObstacleEKF(T)
    for _ in range(20):
        ekf.step([9.0, -0.5])
    assert ekf.step(first) == "outlier" and ekf.step((9.0, -0.5)) == "update" and ekf.maneuvers_ == 0


def test_controller_counts_missed_measurements_and_outliers():
    from casadi_gpc.planner.gpc import GPCController
    cfg = PRESETS["paper"]
    ctrl = GPCController(cfg)
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(10.0),), 0.4)
    T = cfg.sample_time_s
    zs = [OBSTACLE.state_at(k * T)[:2] for k in range(12)]
    zs = [(float(x), float(y)) for x, y in zs]
    zs[5] = None
    zs[8] = (zs[8][0] + 4.0, zs[8][1])
    for k, z in enumerate(zs):
        obs = Observation(k * T, RobotState(0.0, 0.0, 0.0), ref, (ObstacleMeasurement(0, z, 0.3),))
        forecasts = ctrl.estimate(obs)
        # the glitch's sample: the track and the ghost standing where it was measured
        assert len(forecasts) == (2 if k == 8 else 1) and forecasts[0].means_m.shape == (cfg.horizon, 2)
    assert ctrl.counters["missed_measurements"] == 1
    assert ctrl.counters["outliers"] == 1 and ctrl.counters["ghosts"] == 1


def _matrix_step(ekf: ObstacleEKF, s: np.ndarray, P: np.ndarray, z) -> tuple[np.ndarray, np.ndarray]:
    """One propagation and (if ``z``) Joseph-form correction in plain matrix form: the
    independent reference for the filter's written-out closed form."""
    T = ekf.sample_time_s
    F = _jacobian(s, T)
    s, P = obstacle_model_step(s, T), F @ P @ F.T + ekf._Q()
    if z is None:
        return s, P
    Hm, R = np.eye(2, 5), ekf._R()
    S = Hm @ P @ Hm.T + R
    K = P @ Hm.T @ np.linalg.inv(S)
    s = s + K @ (np.asarray(z) - Hm @ s)
    s[3] = (s[3] + np.pi) % (2 * np.pi) - np.pi
    IKH = np.eye(5) - K @ Hm
    return s, IKH @ P @ IKH.T + K @ R @ K.T


@pytest.mark.parametrize("T", SAMPLE_TIMES)
def test_closed_form_matches_the_matrix_form(T):
    """The filter's written-out step and prediction equal F P F^T + Q and the Joseph update
    in matrix form, from random states and covariances (one step: rounding only)."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        ekf = ObstacleEKF(T)
        ekf.step((0.0, 0.0))
        ekf.step((0.2, 0.1))  # initialised; state and covariance replaced below
        s = np.array([*rng.normal(0, 5, 2), rng.uniform(0, 1.5), rng.uniform(-4, 4), rng.normal(0, 0.2)])
        L = rng.normal(0, 0.3, (5, 5))
        P = L @ L.T + 1e-4 * np.eye(5)
        ekf.state_, ekf.cov_ = s.copy(), P.copy()
        means, covs = ekf.predict(6)
        ws, wP = s, P
        for j in range(6):
            ws, wP = _matrix_step(ekf, ws, wP, None)
            np.testing.assert_allclose(means[j], ws[:2], rtol=0, atol=1e-13 * (1 + np.abs(ws[:2]).max()))
            np.testing.assert_allclose(covs[j], wP[:2, :2], rtol=0, atol=1e-13 * np.abs(wP).max())
        ahead = obstacle_model_step(s, T)
        z = (float(ahead[0] + rng.normal(0, 0.05)), float(ahead[1] + rng.normal(0, 0.05)))
        want_s, want_P = _matrix_step(ekf, s, P, z)
        assert ekf.step(z) == "update"
        np.testing.assert_allclose(ekf.state_, want_s, rtol=0, atol=1e-13 * (1 + np.abs(want_s).max()))
        np.testing.assert_allclose(ekf.cov_, want_P, rtol=0, atol=1e-13 * np.abs(want_P).max())
        assert np.array_equal(ekf.cov_, ekf.cov_.T)


def test_a_track_seen_once_is_planned_with_its_next_step_uncertainty():
    from casadi_gpc.estimation.obstacle_model import planning_covariances
    ekf = ObstacleEKF(0.5)
    ekf.step(np.array([5.0, 1.0]))
    assert not ekf.initialised
    means, covs = ekf.predict(12)
    assert covs[-1, 0, 0] > 100 * covs[0, 0, 0]  # the raw forecast's uncertainty grows
    held = planning_covariances(covs, ekf.initialised)
    np.testing.assert_array_equal(held, np.repeat(covs[:1], 12, axis=0))
    ekf.step(np.array([5.1, 1.0]))
    assert ekf.initialised
    _, covs2 = ekf.predict(12)
    np.testing.assert_array_equal(planning_covariances(covs2, ekf.initialised), covs2)


def test_velocity_is_speed_times_heading_and_zero_for_a_track_seen_once():
    ekf = ObstacleEKF(0.5)
    assert ekf.velocity_mps == (0.0, 0.0)                       # no estimate yet
    ekf.step((1.0, 2.0))
    assert ekf.velocity_mps == (0.0, 0.0)                       # seen once: planned standing
    for k in range(1, 8):                                        # 0.3 m/s along +x, 0.4 along +y
        ekf.step((1.0 + 0.15 * k, 2.0 + 0.2 * k))
    x, y, v, heading, _ = ekf.state_
    assert ekf.velocity_mps == (v * math.cos(heading), v * math.sin(heading))
    np.testing.assert_allclose(ekf.velocity_mps, (0.3, 0.4), atol=0.02)


def test_the_straight_forecast_holds_speed_and_heading_and_matches_monte_carlo():
    """``straight``: the forecast moves on at the estimated speed and heading (exact chords of
    V T from the estimate) whatever turn the filter estimated, and its covariances are those
    of the model with the turn increment fixed at zero (Monte Carlo of that model with the
    filter's other uncertainties, within 20 %); the turning forecast of the same filter
    curves away from it."""
    T, H = 0.5, 12
    ekf = run_filter(T, 40, noise=0.02, seed=3)
    x, y, v, th, dth = ekf.state_
    assert abs(dth) > 0.05  # the obstacle turns: the two forecasts differ
    means, covs = ekf.predict(H, straight=True)
    k = np.arange(1, H + 1)
    np.testing.assert_allclose(means, np.c_[x + k * v * T * np.cos(th), y + k * v * T * np.sin(th)], atol=1e-12)
    turning, _ = ekf.predict(H)
    assert np.hypot(*(turning[-1] - means[-1])) > 1.0
    P = ekf.cov_.copy()
    P[4, :] = P[:, 4] = 0.0
    Q = np.diag(np.diag(ekf._Q()))
    Q[4, 4] = 0.0
    rng = np.random.default_rng(8)
    n = 40000
    s = rng.multivariate_normal(ekf.state_ * [1, 1, 1, 1, 0], P, n)
    for j in range(H):
        s = obstacle_model_step(s, T) + rng.multivariate_normal(np.zeros(5), Q, n)
        c = np.cov(s[:, :2].T)
        assert np.linalg.norm(c - covs[j]) / np.linalg.norm(covs[j]) < 0.2, j
    # the planner's faster form gives the same numbers
    from casadi_gpc.estimation.forecast_function import ForecastFunction
    fm, fc = ekf.predict(H, ForecastFunction(T, H), straight=True)
    np.testing.assert_allclose(fm, means, atol=1e-12)
    np.testing.assert_allclose(fc, covs, rtol=1e-9, atol=1e-15)


def test_the_planner_forecasts_as_its_preset_says():
    """``PlannerConfig.forecast``: the paper's preset keeps the turning model, ``improved``
    forecasts straight; an unknown model is refused."""
    from casadi_gpc.config import PlannerConfig
    assert PRESETS["paper"].forecast == "turn" and PRESETS["improved"].forecast == "straight"
    with pytest.raises(ValueError, match="forecast"):
        PlannerConfig(name="x", sample_time_s=0.5, forecast="curvy")
    # the planner plans with its preset's forecast of each filter
    pytest.importorskip("casadi")
    from casadi_gpc.planner.gpc import GPCController
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(20.0),), 0.4)
    for name in ("paper", "improved"):
        gpc = GPCController(PRESETS[name])
        T, H = gpc.sample_time_s, gpc.horizon
        for k in range(12):
            x, y, _ = OBSTACLE.state_at(k * T)
            forecasts = gpc.estimate(Observation(k * T, RobotState(0.0, -5.0, 0.0, 0.0, 0.0), ref,
                                                 (ObstacleMeasurement(0, (x, y), 0.3),), ()))
        ekf = gpc.tracks[0]
        straight, turning = ekf.predict(H, straight=True)[0], ekf.predict(H)[0]
        assert np.hypot(*(straight[-1] - turning[-1])) > 0.05
        np.testing.assert_allclose(forecasts[0].means_m, straight if name == "improved" else turning, atol=1e-9)
    with pytest.raises(ValueError, match="cold_starts"):
        PlannerConfig(name="x", sample_time_s=0.5, cold_starts=0)


@pytest.mark.parametrize("horizon, T", [(1, 0.5), (12, 0.5), (18, 0.4), (60, 0.1)])
def test_a_track_seen_once_is_forecast_standing_with_a_growing_uncertainty_as_written_step_by_step(horizon, T):
    """The forecast of a track seen once (speed unknown): standing where it was seen, the
    covariance at step j the position's plus I (initial speed std x T)^2 j^2. The shipped form
    makes all steps at once; here the step-by-step form it replaced, to the bit."""
    rng = np.random.default_rng(horizon)
    settings = EKFSettings(measurement_std_m=float(rng.uniform(0.005, 0.1)),
                           initial_speed_std_mps=float(rng.uniform(0.3, 2.0)))
    ekf = ObstacleEKF(T, settings)
    ekf.step((float(rng.normal(0, 5)), float(rng.normal(0, 5))))
    snap = ekf.snapshot()
    assert snap.measurements_seen == 1
    means, covs = snap.predict(horizon)
    s, P = np.array(snap.state), snap.cov_array()
    grow = (settings.initial_speed_std_mps * T) ** 2
    want_m, want_c = np.empty((horizon, 2)), np.empty((horizon, 2, 2))
    for j in range(horizon):
        want_m[j] = s[:2]
        want_c[j] = P[:2, :2] + np.eye(2) * grow * (j + 1) ** 2
    np.testing.assert_array_equal(means, want_m)
    np.testing.assert_array_equal(covs, want_c)
