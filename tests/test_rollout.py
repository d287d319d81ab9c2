"""A one-command network's roll-out (nn_export/runtime/rollout.py) against the features of
the predicted situations built the public way, and the check layer that judges it as the
network's plan (CheckSettings(rollouts=True))."""
from __future__ import annotations

import numpy as np
import pytest

from casadi_gpc.config import preset
from casadi_gpc.planner.gpc import GPCController
from casadi_gpc.robot import RobotParams, RobotState, robot_step_float
from casadi_gpc.safety import CheckSettings, Shield, StandbyPlanner
from scenarios.simulator import simulate
from nn_export import OnnxPolicy
from nn_export.runtime.features import compute_features
from nn_export.runtime.situation import Situation, TrackEstimate, reference_rows
from scenarios import Suite

CFG = preset("improved")
H, T = CFG.horizon, CFG.sample_time_s


def _crowd_scene(episode: int = 0):
    return Suite("circle-crossing", 1, 1, 10, "orca").scenario(episode)


class _Recording:
    """The policy, recording each observation and its decision."""

    def __init__(self, policy):
        self.policy, self.sample_time_s, self.horizon = policy, policy.sample_time_s, policy.horizon
        self.seen = []

    def reset(self):
        self.policy.reset()

    def decide(self, obs):
        d = self.policy.decide(obs)
        self.seen.append((obs, d))
        return d


def test_the_roll_out_is_the_network_on_the_predicted_situations():
    """Step j of the roll-out: the network's answer on the features of the situation j steps
    ahead (the robot where the plan so far takes it, the desired poses from step j, each
    walker where its forecast puts it, heading turned j times), built as a Situation and
    computed by compute_features, then held to the wheel limits."""
    sc = _crowd_scene()
    # the decision then hands over the very estimates the roll-out reads (the turning forecast);
    # what it hands a check by default, and that the roll-out does not depend on it, is
    # tests/test_check_forecast.py's
    pol = OnnxPolicy(preset="improved", robot=sc.robot, check_forecast="turn")
    rec = _Recording(pol)
    simulate(sc, rec, "nn")
    obs, dec = rec.seen[12]
    pol.reset()
    for o, _ in rec.seen[:13]:       # the same stream again, up to that decision
        d = pol.decide(o)
    assert (d.v_right_mps, d.v_left_mps) == (dec.v_right_mps, dec.v_left_mps)
    wheels, poses = pol.rollout()
    assert wheels.shape == (H, 2) and poses.shape == (H, 3)
    assert tuple(wheels[0]) == (d.v_right_mps, d.v_left_mps)
    assert d.reason == "one pass: crowd network"      # the set network reads the crowd here
    layout, net = pol._crowd.layout, pol._crowd.session
    rows = np.array(reference_rows(obs.reference, pol.tracker.clock.s_m, T, 2 * H - 1))
    rp = RobotParams() if sc.robot is None else sc.robot
    dv, vmax = rp.max_step_change_mps(T), rp.max_wheel_speed_mps
    x, y, th = obs.robot.x_m, obs.robot.y_m, obs.robot.heading_rad
    vr, vl = wheels[0]
    x, y, th = robot_step_float(x, y, th, vr, vl, T, rp.wheel_base_m)
    np.testing.assert_allclose(poses[0], (x, y, th), rtol=0, atol=1e-12)
    for j in range(1, H):
        ahead = []
        for t in d.forecasts:
            s = np.array(t.state, dtype=float)
            s[:2] = t.means_m[j - 1]
            s[3] += j * s[4]
            ahead.append(TrackEstimate(t.obstacle_id, t.radius_m, s, t.cov, t.means_m[j - 1:], t.covs_m2,
                                       t.initialised))
        sit = Situation(RobotState(x, y, th, vr, vl), rows[j:j + H + 1], T, obs.reference.speed_mps, tuple(ahead),
                        tuple(obs.static))
        f = compute_features(layout, sit).astype(np.float32)[None]
        nr, nl = net.run(None, {net.get_inputs()[0].name: f})[0][0, :2].tolist()
        vr = min(vmax, max(-vmax, min(vr + dv, max(vr - dv, nr))))
        vl = min(vmax, max(-vmax, min(vl + dv, max(vl - dv, nl))))
        np.testing.assert_allclose(wheels[j], (vr, vl), rtol=0, atol=1e-6)
        vr, vl = wheels[j]
        x, y, th = robot_step_float(x, y, th, vr, vl, T, rp.wheel_base_m)
        np.testing.assert_allclose(poses[j], (x, y, th), rtol=0, atol=1e-12)
    assert np.all(np.abs(np.diff(wheels, axis=0)) <= dv + 1e-12) and np.all(np.abs(wheels) <= vmax)


def test_the_check_lets_a_command_through_on_its_roll_out_only_when_the_roll_out_keeps_clear():
    """The shipped networks among 10 walkers behind the check with roll-outs: where a command
    failed alone and went through on its roll-out, that roll-out starts with the command,
    and the check run afresh on it (the same forecasts) keeps the margin over the whole
    horizon; every roll-out asked for is counted. (Episode 2: seven commands fail alone and
    pass on their roll-out; checked without roll-outs, the check steps in.)"""
    sc = _crowd_scene(2)
    robot = sc.robot or RobotParams()
    sh = Shield(OnnxPolicy(preset="improved", robot=robot), robot,
                CheckSettings(rollouts=True, fallback="planner"), standby=StandbyPlanner(GPCController(CFG, robot)))
    rec = _Recording(sh)
    log = simulate(sc, rec, "nn")
    c = sh.counters
    assert c["shield_rollouts"] > 0 and 0 < c["shield_rollout_passed"] <= c["shield_rollouts"]
    assert c["shield_rollout_trusted"] == 0      # no trust time: the whole horizon
    through = [(o, d) for o, d in rec.seen if "rollout_wheels_mps" in d.info]
    assert len(through) == c["shield_rollout_passed"]
    for o, d in through:
        plan = d.info["rollout_wheels_mps"]
        assert tuple(plan[0]) == (d.v_right_mps, d.v_left_mps) and not d.fallback
        again = sh.filter.check(o.robot.as_array(), plan, d.forecasts, o.static)
        assert again.safe and again.continuation in ("plan", "bound")
    assert log.outcome in ("reached_goal", "timed_out")
    # without roll-outs the same controller is checked as before: none asked for
    plain = Shield(OnnxPolicy(preset="improved", robot=robot), robot)
    simulate(sc, plain, "nn")
    assert plain.counters["shield_rollouts"] == 0 and plain.counters["interventions"] > c["interventions"]


def test_a_trusted_roll_out_passes_when_it_keeps_the_margin_that_long():
    """With ``trust_rollout_s`` (the shipped ``--controller nn``), a roll-out that keeps the
    margin for that long passes even where it fails later in the horizon, and each such pass
    is counted apart: on a crowd episode, every command let through on its roll-out re-checks
    as keeping the margin at least the trust time, those that fail over the whole horizon are
    exactly the ones counted ``rollout_trusted`` (episode 6: six of seven), and the check
    steps in less often than with the whole horizon (three against ten)."""
    from casadi_gpc.safety import ROLLOUT_TRUST_S
    sc = _crowd_scene(6)
    robot = sc.robot or RobotParams()

    def run(trust):
        sh = Shield(OnnxPolicy(preset="improved", robot=robot), robot,
                    CheckSettings(rollouts=True, trust_rollout_s=trust, fallback="planner"),
                    standby=StandbyPlanner(GPCController(CFG, robot)))
        rec = _Recording(sh)
        simulate(sc, rec, "nn")
        return sh, rec

    sh, rec = run(ROLLOUT_TRUST_S)
    c = sh.counters
    through = [(o, d) for o, d in rec.seen if "rollout_wheels_mps" in d.info]
    assert len(through) == c["shield_rollout_passed"] > 0
    beyond = 0
    for o, d in through:
        plan = d.info["rollout_wheels_mps"]
        assert tuple(plan[0]) == (d.v_right_mps, d.v_left_mps) and not d.fallback
        again = sh.filter.check(o.robot.as_array(), plan, d.forecasts, o.static)
        assert again.safe or again.kept_s >= ROLLOUT_TRUST_S - 1e-9
        beyond += not again.safe
    assert beyond == c["shield_rollout_trusted"] > 0
    whole, _ = run(None)
    assert whole.counters["shield_rollout_trusted"] == 0
    assert c["interventions"] < whole.counters["interventions"]
    with pytest.raises(ValueError, match="trust_rollout_s"):
        Shield(OnnxPolicy(preset="improved", robot=robot), robot, CheckSettings(rollouts=True, trust_rollout_s=-1.0))


def test_rollouts_need_a_controller_that_rolls_out():
    class _NoRollout:
        sample_time_s, horizon = T, H

        def reset(self):
            pass

        def decide(self, obs):
            raise AssertionError

    with pytest.raises(TypeError, match="rollout"):
        Shield(_NoRollout(), settings=CheckSettings(rollouts=True))
