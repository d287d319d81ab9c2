"""Injected faults and what must come out of them: the estimate after a dropout, a gated
outlier that leaves the estimate alone, NaN and infinity treated as missing, late
measurements, an obstacle first seen close by, solves that fail, return NaN or run out of
their time budget. Every test asserts an outcome, not only that nothing raised."""
from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest

from casadi_gpc.config import preset
from casadi_gpc.estimation.ekf import ObstacleEKF
from casadi_gpc.robot import RobotParams
from scenarios.simulator import simulate
from casadi_gpc.types import ObstacleMeasurement
from scenarios import Faults, load_scenario
from scenarios.model import MovingObstacleSpec

from conftest import PAPER_DIR

ROBOT = RobotParams()
T = 0.5
STRAIGHT = MovingObstacleSpec((2.0, -1.0), 0.6, 0.4, 0.3)
TURNING = MovingObstacleSpec((2.0, -1.0), 0.6, 0.4, 0.3, 0.15)
HEAD_ON, CROSSING = PAPER_DIR / "fig7_1_head_on.toml", PAPER_DIR / "fig7_2_crossing.toml"


def measurements(spec, n, noise=0.02, seed=0):
    rng = np.random.default_rng(seed)
    return [np.array(spec.state_at(k * T)[:2]) + rng.normal(0.0, noise, 2) for k in range(n)]


def run(zs, settings=None):
    ekf = ObstacleEKF(T)
    events = [ekf.step(z) for z in zs]
    return ekf, events


# --- the EKF ---------------------------------------------------------------------------------
@pytest.mark.parametrize("spec", [STRAIGHT, TURNING], ids=["straight", "turning"])
def test_estimate_after_a_five_step_dropout_stays_near_the_truth(spec):
    """20 measurements, then 5 missing: the predicted position stays within 6 cm of the truth
    at every missing step, inside 3 predicted standard deviations, and the first
    measurement after the gap is fused (not mistaken for an outlier)."""
    zs = measurements(spec, 26, seed=4)
    ekf, _ = run(zs[:20])
    for k in range(20, 25):
        assert ekf.step(None) == "missed"
        truth = np.array(spec.state_at(k * T)[:2])
        err = np.hypot(*(ekf.state_[:2] - truth))
        sd = np.sqrt(np.linalg.eigvalsh(ekf.cov_[:2, :2]).max())
        assert err < 0.06 and err < 3.0 * sd, (k, err, sd)
    assert ekf.missed_ == 5
    assert ekf.step(zs[25]) == "update"
    assert np.hypot(*(ekf.state_[:2] - np.array(spec.state_at(25 * T)[:2]))) < 0.04


def test_outlier_five_metres_away_is_rejected_and_leaves_the_estimate_alone():
    """An outlier is exactly a missing update: the filter with a 5 m jump at step 15 equals,
    bit for bit, the filter that missed that measurement, and stays within 1 cm of the
    fault-free filter afterwards."""
    zs = measurements(TURNING, 30, seed=9)
    jumped = list(zs)
    jumped[15] = zs[15] + np.array([3.0, 4.0])
    dropped = list(zs)
    dropped[15] = None
    a, ev_a = run(jumped)
    b, _ = run(dropped)
    c, _ = run(zs)
    assert ev_a[15] == "outlier" and a.outliers_ == 1 and a.missed_ == 0
    np.testing.assert_array_equal(a.state_, b.state_)
    np.testing.assert_array_equal(a.cov_, b.cov_)
    assert np.hypot(*(a.state_[:2] - c.state_[:2])) < 0.01


@pytest.mark.parametrize("bad", [[np.nan, 1.0], [1.0, np.inf], [-np.inf, np.nan]])
def test_non_finite_measurement_is_a_missing_one(bad):
    zs = measurements(STRAIGHT, 25, seed=1)
    nan = list(zs)
    nan[12] = np.array(bad, float)
    gap = list(zs)
    gap[12] = None
    a, ev = run(nan)
    b, _ = run(gap)
    assert ev[12] == "missed" and a.missed_ == 1
    np.testing.assert_array_equal(a.state_, b.state_)
    assert np.all(np.isfinite(a.state_)) and np.all(np.isfinite(a.cov_))


# --- closed loop with sensor faults ------------------------------------------------------------
class FirstSeenWithin:
    """Hides every moving obstacle from ``inner`` until it is first measured within
    ``range_m`` (centre distance) of the robot, as if it stepped out from behind a corner."""

    def __init__(self, inner, range_m: float):
        self.inner, self.range_m = inner, range_m
        self.sample_time_s = inner.sample_time_s
        self.first_seen = {}

    def reset(self):
        self.inner.reset()
        self.first_seen = {}

    @property
    def counters(self):
        return self.inner.counters

    def decide(self, obs):
        out = []
        for m in obs.moving:
            if m.obstacle_id not in self.first_seen and m.position_m is not None:
                d = np.hypot(m.position_m[0] - obs.robot.x_m, m.position_m[1] - obs.robot.y_m)
                if d <= self.range_m:
                    self.first_seen[m.obstacle_id] = d
            out.append(m if m.obstacle_id in self.first_seen else ObstacleMeasurement(m.obstacle_id, None, m.radius_m))
        return self.inner.decide(replace(obs, moving=tuple(out)))


class NonFinite:
    """Replaces the measurement at the given sample indices by NaN or infinity."""

    def __init__(self, inner, steps: dict):
        self.inner, self.steps = inner, steps
        self.sample_time_s = inner.sample_time_s

    def reset(self):
        self.inner.reset()
        self.k = 0

    @property
    def counters(self):
        return self.inner.counters

    def decide(self, obs):
        bad = self.steps.get(self.k)
        self.k += 1
        if bad is not None:
            obs = replace(obs, moving=tuple(ObstacleMeasurement(m.obstacle_id, bad, m.radius_m) for m in obs.moving))
        return self.inner.decide(obs)


TOL_MPS = 1e-6  # the solvers meet bounds to their tolerance (IPOPT: 1e-8), not to the last bit


def assert_commands_finite_within_limits(log, controller_name):
    """Every command the controller gave is finite and within the speed and acceleration
    limits from the wheel speeds it was given (not merely clipped by the simulator)."""
    st = np.asarray(log.states)
    dv = ROBOT.max_step_change_mps(log.sample_time_s)
    for k, d in enumerate(log.decisions):
        cmd = np.array([d.v_right_mps, d.v_left_mps])
        assert np.all(np.isfinite(cmd)), (controller_name, k)
        assert np.all(np.abs(cmd) <= ROBOT.max_wheel_speed_mps + TOL_MPS), (controller_name, k, cmd)
        assert np.all(np.abs(cmd - st[k, 3:5]) <= dv + TOL_MPS), (controller_name, k, cmd, st[k, 3:5])
    assert log.events.get("non_finite_commands", 0) == 0


@pytest.fixture(scope="module")
def gpc():
    pytest.importorskip("casadi")
    from casadi_gpc.planner.gpc import GPCController
    return GPCController(preset("improved"))


@pytest.mark.parametrize("path", [HEAD_ON, CROSSING], ids=["head_on", "crossing"])
def test_gpc_avoids_an_obstacle_first_seen_1_5_m_away(gpc, path):
    """Under the default preset (T = 0.5 s). At T = 1.5 s (preset paper) the robot and
    the obstacle close 1.2 m in one interval, so no controller can react to something first
    seen 1.5 m away (docs/faults.md)."""
    hidden = FirstSeenWithin(gpc, 1.5)
    log = simulate(load_scenario(path), hidden, "gpc")
    assert log.outcome == "reached_goal" and log.min_clearance_m > 0.05
    assert 1.2 < hidden.first_seen[0] <= 1.5
    assert log.events["missed_measurements"] >= 20  # every hidden sample counted
    assert_commands_finite_within_limits(log, "gpc")


def test_gpc_with_every_sensor_fault_of_the_faults_table(gpc, write_scenario):
    """Dropouts, 5 m outliers and measurements one sample late, from a scenario file:
    no collision, every injected fault and every gated outlier counted."""
    text = HEAD_ON.read_text() + """
[faults]
dropout_prob = 0.2
outlier_prob = 0.1
outlier_distance_m = 5.0
delay_steps = 1
"""
    s = load_scenario(write_scenario(text))
    assert s.faults == Faults(0.2, 0.1, 5.0, 1, 0.0)
    log = simulate(s, gpc, "gpc")
    ev = log.events
    assert log.outcome == "reached_goal" and log.min_clearance_m > 0.05
    assert ev["injected_dropouts"] > 0 and ev["injected_outliers"] > 0
    # the controller saw each dropout (plus the first, late, sample) as missing ...
    assert ev["missed_measurements"] >= ev["injected_dropouts"]
    # ... and gated the outliers that were not also dropped
    assert ev["outliers"] >= 1
    assert_commands_finite_within_limits(log, "gpc")
    # reproducible from the file
    again = simulate(s, gpc, "gpc")
    np.testing.assert_array_equal(np.asarray(again.states), np.asarray(log.states))


def test_gpc_with_nan_and_inf_measurements(gpc):
    steps = {k: (float("nan"), 1.0) if k % 2 else (float("inf"), float("-inf")) for k in range(10, 16)}
    wrapped = NonFinite(gpc, steps)
    log = simulate(load_scenario(HEAD_ON), wrapped, "gpc")
    assert log.outcome == "reached_goal" and log.min_clearance_m > 0.05
    assert log.events["missed_measurements"] == len(steps)
    assert_commands_finite_within_limits(log, "gpc")


# --- solver faults ---------------------------------------------------------------------------
def test_every_solve_failing_brakes_within_the_limits_and_never_collides(write_scenario):
    """solver_failure_prob = 1 from the file, after the robot got going (a static obstacle on
    the path ahead): the GPC follows what is left of its last plan, then brakes at the
    acceleration limit, stops, and never touches the obstacle."""
    pytest.importorskip("casadi")
    from casadi_gpc.planner.gpc import GPCController

    ctrl = GPCController(preset("improved"))
    text = """
name = "brake_test"
duration_s = 20.0
[robot]
position = [0.0, 0.0]
heading_deg = 0.0
[reference]
position = [0.0, 0.0]
heading_deg = 0.0
speed_mps = 0.4
[[reference.segments]]
line_m = 12.0
[[static_obstacles]]
position = [4.0, 0.0]
radius_m = 0.3
[faults]
solver_failure_prob = 1.0
"""
    s = load_scenario(write_scenario(text))
    assert s.faults.solver_failure_prob == 1.0

    class LateFailures:
        """Normal solves for 4 samples (the robot gets up to speed), then the file's faults."""

        sample_time_s = ctrl.sample_time_s

        def __init__(self):
            self.counters = ctrl.counters

        def reset(self):
            ctrl.reset()
            self.counters = ctrl.counters
            self.k = 0

        def inject_failures(self, p, rng):
            self.prob, self.rng = p, rng

        def decide(self, obs):
            if self.k == 4:
                ctrl.inject_failures(self.prob, self.rng)
            self.k += 1
            return ctrl.decide(obs)

    try:
        log = simulate(s, LateFailures(), "gpc")
    finally:
        ctrl.inject_failures(0.0)
    st = np.asarray(log.states)
    n = len(log.decisions)
    assert log.outcome == "timed_out" and log.min_clearance_m > 0.3
    assert st[4, 3] > 0.2  # it was moving when the failures began
    assert log.fallbacks == n - 4 == ctrl.counters["injected_failures"] == ctrl.counters["fallbacks"]
    assert all(d.fallback for d in log.decisions[4:])
    assert_commands_finite_within_limits(log, "gpc")
    # stopped within the shifted plan's H - 1 steps plus the braking steps, and stays stopped
    dv = ROBOT.max_step_change_mps(T)
    stop_by = 4 + (ctrl.config.horizon - 1) + int(np.ceil(ROBOT.max_wheel_speed_mps / dv))
    assert np.all(st[stop_by:, 3:5] == 0.0)
    reasons = [d.reason for d in log.decisions[4:]]
    assert reasons[-1].startswith("brake; injected solver failure")


class _FakeSolver:
    """Stands in for the CasADi solver inside the GPC's backend (its buffered call,
    ``casadi_gpc.buffered.BufferedFunction``)."""

    def __init__(self, real, mode, sleep_s=0.0):
        self.real, self.mode, self.sleep_s = real, mode, sleep_s
        self.calls = 0
        self.inputs, self.outputs = real.inputs, real.outputs

    def __call__(self, *args):
        self.calls += 1
        if self.mode == "raise":
            raise RuntimeError("Error in Function::call for 'gpc' [IpoptInterface] at .../casadi.cpp: NaN detected")
        ret = self.real(*args)
        if self.mode == "nan":
            for o in self.outputs:
                o[:] = np.nan
        if self.mode == "slow":
            time.sleep(self.sleep_s)
        return ret

    def stats(self):
        return self.real.stats()


@pytest.mark.parametrize("mode", ["raise", "nan"])
def test_a_solve_that_raises_or_returns_nan_is_a_counted_fallback(mode):
    pytest.importorskip("casadi")
    from casadi_gpc.planner.gpc import GPCController

    # one CasADi solver behind the backend (one lane: the fake stands in for that solver's
    # buffer, a second lane would have its own), and no second try by the backup solver (issue 3)
    ctrl = GPCController(preset("improved").with_overrides(solver="sqpmethod-daqp", solve_lanes=1), backup_solver=None)
    real = ctrl.backend.solver
    s = load_scenario(HEAD_ON)
    log_ok = simulate(replace(s, duration_s=3.0), ctrl, "gpc")
    ctrl.backend.solver = _FakeSolver(real, mode)
    log = simulate(replace(s, duration_s=3.0), ctrl, "gpc")
    assert log.fallbacks == len(log.decisions) == ctrl.counters["fallbacks"]
    assert ctrl.counters["failed_solves"] == ctrl.counters["solves"] == ctrl.backend.solver.calls > 0
    assert all(("error" in d.reason) if mode == "raise" else ("all solves failed" in d.reason)
               for d in log.decisions)
    assert_commands_finite_within_limits(log, "gpc")
    # from rest, every fallback is a brake that keeps the robot where it was
    assert np.all(np.asarray(log.states)[:, :2] == 0.0)
    assert log_ok.fallbacks == 0


def test_a_solve_over_its_time_budget_does_not_block_the_loop():
    """A solver that takes 0.12 s against a 0.05 s budget: the late answer is not used, the
    remaining starts are skipped, the step returns after one solve, counted."""
    pytest.importorskip("casadi")
    from casadi_gpc.planner.gpc import GPCController

    # every guess at once (not one cold start a tick): there are starts left to skip
    ctrl = GPCController(replace(preset("improved").with_overrides(time_budget_s=0.05, solver="sqpmethod-daqp",
                                                                   solve_lanes=1), cold_starts=None))
    ctrl.backend.solver = _FakeSolver(ctrl.backend.solver, "slow", sleep_s=0.12)
    s = load_scenario(HEAD_ON)
    log = simulate(replace(s, duration_s=2.0), ctrl, "gpc")
    assert log.fallbacks == len(log.decisions) == ctrl.counters["fallbacks"] == ctrl.counters["over_budget"]
    assert ctrl.counters["solves"] == len(log.decisions)  # one solve per step, never the others
    assert ctrl.counters["budget_skips"] >= 1
    assert max(log.compute_time_s) < 0.12 + 0.1  # one solve, not four
    assert all("over the time budget" in d.reason for d in log.decisions)
    assert_commands_finite_within_limits(log, "gpc")


# --- the network under sensor faults -------------------------------------------------------------
@pytest.fixture(scope="module")
def tracker_path(tmp_path_factory):
    from synthetic_models import tracker_model
    return tracker_model(tmp_path_factory.mktemp("models") / "tracker.onnx", "improved")


def _policy(path, shield: bool = True):
    """The network, behind the check layer (manoeuvres only, no planner) unless told not."""
    from casadi_gpc.safety import Shield
    from nn_export import OnnxPolicy
    net = OnnxPolicy(path, preset="improved")
    return Shield(net) if shield else net


@pytest.mark.parametrize("path", [HEAD_ON, CROSSING], ids=["head_on", "crossing"])
def test_filtered_network_survives_an_obstacle_first_seen_1_5_m_away(tracker_path, path):
    """The obstacle-blind network with the safety filter (manoeuvres only, no planner): no
    collision; the hidden samples counted as missing; the interventions as fallbacks."""
    pol = _policy(tracker_path)
    hidden = FirstSeenWithin(pol, 1.5)
    log = simulate(load_scenario(path), hidden, "nn")
    assert log.outcome != "collided" and log.min_clearance_m > 0.0
    assert 1.2 < hidden.first_seen[0] <= 1.5
    assert log.events["missed_measurements"] >= 20
    assert log.fallbacks == log.events["interventions"] > 0
    assert_commands_finite_within_limits_of_fallbacks(log)


def assert_commands_finite_within_limits_of_fallbacks(log):
    """All commands finite and within the speed limit; the filter's own commands within
    the acceleration limit too (the network's raw output may ask for more, which the filter
    checks as the robot would follow it and counts in ``shield_candidate_limited``)."""
    st = np.asarray(log.states)
    dv = ROBOT.max_step_change_mps(log.sample_time_s)
    for k, d in enumerate(log.decisions):
        cmd = np.array([d.v_right_mps, d.v_left_mps])
        assert np.all(np.isfinite(cmd)) and np.all(np.abs(cmd) <= ROBOT.max_wheel_speed_mps + TOL_MPS)
        if d.fallback:
            assert np.all(np.abs(cmd - st[k, 3:5]) <= dv + TOL_MPS)
    assert log.events.get("non_finite_commands", 0) == 0


@pytest.mark.parametrize("safety", [True, False], ids=["filtered", "bare"])
def test_network_with_dropouts_outliers_delays_and_nan(tracker_path, write_scenario, safety):
    """Every sensor fault at once, from the file, plus NaN/inf measurements: finite commands
    within the limits, every event counted, the same EKF accounting as the GPC's."""
    text = CROSSING.read_text() + """
[faults]
dropout_prob = 0.2
outlier_prob = 0.1
outlier_distance_m = 5.0
delay_steps = 1
"""
    s = load_scenario(write_scenario(text))
    pol = _policy(tracker_path, shield=safety)
    steps = {k: (float("nan"), 0.0) for k in range(20, 24)}
    log = simulate(s, NonFinite(pol, steps), "nn")
    ev = log.events
    assert ev["injected_dropouts"] > 0 and ev["injected_outliers"] > 0 and ev["outliers"] >= 1
    assert ev["missed_measurements"] >= ev["injected_dropouts"]
    assert_commands_finite_within_limits_of_fallbacks(log)
    if safety:
        assert log.outcome != "collided"
        assert log.fallbacks == ev["interventions"]
    else:
        assert log.fallbacks == 0 and "shield_checks" not in ev


def test_the_check_layer_passes_solver_failures_on_and_a_network_says_it_has_no_solver():
    """The default --controller gpc runs behind the check layer, which did not pass the fault on:
    EVAL.json recorded solver_failure_prob 1 over a run with no failure injected."""
    pytest.importorskip("casadi")
    from dataclasses import replace
    from gpcnav.controllers import ControllerSpec, make
    from scenarios import Faults, Suite
    from scenarios.simulator import simulate
    sc = Suite("encounters", 1, 3).scenario(0)
    sc = replace(sc, faults=Faults(solver_failure_prob=1.0), duration_s=6.0)
    gpc = make(ControllerSpec("gpc"), preset("improved"), sc.robot)
    log = simulate(sc, gpc, "gpc")
    assert log.events["injected_failures"] == len(log.decisions) > 0 and log.fallbacks == len(log.decisions)
    assert "solver_failures_not_applied" not in log.events
    nn = make(ControllerSpec("nn"), preset("improved"), sc.robot)
    assert simulate(sc, nn, "nn").events["solver_failures_not_applied"] == 1
    assert "solver_failures_not_applied" not in simulate(replace(sc, faults=Faults()), nn, "nn").events


@pytest.mark.parametrize("spec, words", [
    ("dropout_prob=1.5", "faults.dropout_prob: must be at most 1.0"),
    ("delay_steps=-1", "faults.delay_steps: must not be negative"),
    ("outlier_distance_m=0", "faults.outlier_distance_m: must be positive"),
    ("solver_failure_prob=nan", "faults.solver_failure_prob: must be finite"),
    ("dropout_prob=0.1,dropout_prob=0.2", "dropout_prob given twice"),
    ("", "--faults takes NAME=VALUE"),
    ("delay_steps=1.5", "delay_steps needs a whole number, got '1.5'"),  # (it said "needs a number")
    ("outlier_prob=x", "outlier_prob needs a number, got 'x'"),
])
def test_faults_on_the_command_line_are_checked_as_a_file_s_are(spec, words):
    """They ran (dropout_prob=1.5, outlier_distance_m=-2), or stopped after the episodes (NaN)."""
    from gpcnav.commands.evaluate import parse_faults
    from gpcnav.errors import UsageError
    with pytest.raises(UsageError, match=words.replace(".", r"\.")):
        parse_faults(spec)


def test_faults_on_the_command_line_that_replace_a_file_s_own_are_said(write_scenario, capsys):
    """--faults replaced a file's [faults] table without a word (its dropouts gone from its episode);
    now one line on stderr names the file. Files with no table, or the same one, are not named."""
    from gpcnav.cli import build_parser
    from gpcnav.commands.evaluate import scenarios_from_args
    own = write_scenario(HEAD_ON.read_text() + "\n[faults]\ndropout_prob = 0.5\n", name="own.toml")
    plain = write_scenario(HEAD_ON.read_text(), name="plain.toml")
    args = build_parser().parse_args(["evaluate", str(own), str(plain), "--faults", "outlier_prob=0.1"])
    scenarios, _ = scenarios_from_args(args)
    assert all(s.faults == Faults(outlier_prob=0.1) for s in scenarios)
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"gpcnav evaluate: --faults replaces the [faults] table of {own}"]
    scenarios_from_args(build_parser().parse_args(["evaluate", str(own), "--faults", "dropout_prob=0.5"]))
    assert capsys.readouterr().err == ""
