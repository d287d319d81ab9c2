"""Plan networks (issue 14's second design): a set network that outputs the GPC's whole H-step
plan of wheel speeds, run by the deployed policy as a plan, and the check layer that keeps
the shifted previous plan as its safe candidate."""
from __future__ import annotations

import math

import numpy as np
import pytest

from casadi_gpc.config import preset
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState
from casadi_gpc.safety import CheckSettings, Shield
from casadi_gpc.types import ControlDecision, Observation, ObstacleMeasurement, StaticObstacle
from nn_export.runtime.layouts import layout_for

CFG = preset("improved")
H, T = CFG.horizon, CFG.sample_time_s
LAY = layout_for("set", H)


# --- the check layer keeps the shifted previous plan ---------------------------------------------
class _Plans:
    """A controller without forecasts that plays the given plans, one per sample."""

    def __init__(self, plans):
        self.plans, self.k, self.sample_time_s, self.horizon = plans, 0, T, H

    def reset(self):
        self.k = 0

    def decide(self, obs):
        p = np.asarray(self.plans[self.k], dtype=float)
        self.k += 1
        return ControlDecision(float(p[0, 0]), float(p[0, 1]), False, "scripted", p)


def _obs(x, v, t=0.0):
    """The robot at (x, 0) heading east at ``v`` on both wheels, a static disc (r 0.3 m) at (1.2, 0), at ``t``."""
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(20.0),), 0.4)
    return Observation(t, RobotState(x, 0.0, 0.0, v, v), ref, (), (StaticObstacle((1.2, 0.0), 0.3),))


BRAKE = np.array([[0.4, 0.4]] + [[0.0, 0.0]] * (H - 1))  # from 0.8 m/s at the acceleration limit
INTO = np.full((H, 2), 0.8)  # up to 0.8 m/s: at the disc within the interval, no way out


@pytest.mark.parametrize("keep", [True, False])
def test_the_shifted_previous_plan_is_the_safe_candidate(keep):
    """Sample 0: a braking plan, accepted. Sample 1 (0.2 m on, at 0.4 m/s, the disc 1.0 m
    ahead): a plan through the disc. With ``previous_plan`` the shield applies the braking
    plan shifted by one step (stand: 0.35 m of clearance) as the controller's own answer;
    without it, one of its manoeuvres, a fallback."""
    sh = Shield(_Plans([BRAKE, INTO]), settings=CheckSettings(previous_plan=keep))
    first = sh.decide(_obs(0.0, 0.8))
    assert not first.fallback and (first.v_right_mps, first.v_left_mps) == (0.4, 0.4)
    d = sh.decide(_obs(0.2, 0.4, T))  # the next sample
    assert sh.counters["interventions"] == 1
    if keep:
        assert d.info["safety_source"] == "previous_plan" and not d.fallback
        assert "the previous plan, shifted" in d.reason
        np.testing.assert_array_equal(d.planned_wheels_mps, np.concatenate([BRAKE[1:], BRAKE[-1:]]))
        assert (d.v_right_mps, d.v_left_mps) == (0.0, 0.0)
        assert sh.counters["shield_previous_plan_used"] == 1
    else:
        assert d.info["safety_source"].startswith("manoeuvre:") and d.fallback
        assert "shield_previous_plan_used" not in sh.counters
    # what was let through keeps the margin
    chk = sh.filter.check(_obs(0.2, 0.4).robot.as_array(), d.planned_wheels_mps, (), _obs(0.2, 0.4).static)
    assert chk.min_clearance_m >= 0.05


def test_a_reset_forgets_the_previous_plan():
    sh = Shield(_Plans([BRAKE, INTO]), settings=CheckSettings(previous_plan=True))
    sh.decide(_obs(0.0, 0.8))
    sh.reset()
    sh.policy.k = 1
    d = sh.decide(_obs(0.2, 0.4))
    assert d.info["safety_source"] != "previous_plan" and sh.counters["shield_previous_plan_used"] == 0


# --- the plan network --------------------------------------------------------------------------
torch = pytest.importorskip("torch")
pytest.importorskip("onnx")


@pytest.fixture(scope="module")
def plan_model(tmp_path_factory):
    """A small set network trained on synthetic plans that depend on the obstacles (the
    nearest one pushes the wheels apart, more at later steps), exported for one pass."""
    from nn_export.training.export import export_onnx
    from nn_export.training.train import WheelSpeedMLP
    rng = np.random.default_rng(0)
    start, n, w = LAY.set_slots
    X = rng.normal(size=(600, LAY.size))
    slots = X[:, start:start + n * w].reshape(-1, n, w)
    slots[..., 0] = 0.0
    for i, m in enumerate(rng.integers(0, 6, size=len(X))):
        slots[i, rng.permutation(n)[:m], 0] = 1.0
    slots[slots[..., 0] == 0.0] = 0.0
    X[:, start:start + n * w] = slots.reshape(len(X), -1)
    near = np.where(slots[..., 0] > 0, np.hypot(slots[..., 1], slots[..., 2]), 9.0).min(1)
    k = np.arange(1, H + 1) / H
    push = (0.05 / (1 + near))[:, None] * k
    Y = np.stack([0.3 + 0.1 * np.tanh(X[:, :1]) + push, 0.3 - push], axis=2).reshape(len(X), 2 * H)
    m = WheelSpeedMLP(hidden=16, layers=2, architecture="set", encoder_width=12, optimizer="adam", max_epochs=20,
                      random_state=0).fit(X, Y, feature_names=LAY.feature_names)
    d = tmp_path_factory.mktemp("plan")
    m.save(d / "m", {"preset": CFG.name, "horizon": H, "sample_time_s": T, "output": "plan",
                     "planner_config": CFG.to_dict(), "robot": RobotParams().to_dict(), "feature_layout": LAY.name,
                     "feature_layout_version": LAY.version, "feature_layout_spec": LAY.to_dict(),
                     "dataset": {"id": "synthetic"}})
    path = d / "m.onnx"
    export_onnx(d / "m", path, X[:128], decision_passes=1)
    return path, X, m, d / "m"


def _walkers(k, n=5):
    return Observation(k * T, RobotState(0.0, 0.1 * k, math.pi / 2, 0.3, 0.3),
                       ReferencePath((0.0, 0.0), math.pi / 2, (Segment.line(30.0),), 0.4),
                       tuple(ObstacleMeasurement(i, (0.5 * i - 1.0, 3.0 + 0.1 * k), 0.3) for i in range(n)))


def test_the_policy_runs_a_plan_network_as_a_plan(plan_model):
    """The decision's command is the plan's first step, and the plan is the network's output
    on the decision's own input row, bit for bit; the slots' order does not matter."""
    from nn_export import OnnxPolicy
    path, X, m, _ = plan_model
    pol = OnnxPolicy(path, preset="improved")
    assert pol.steps == H and pol.outputs_plans and not pol.two_pass and pol.model_info["output"] == "plan"
    for k in range(4):
        dec = pol.decide(_walkers(k))
    want = pol.network(pol._f64[None, :])[0].reshape(H, 2)
    np.testing.assert_array_equal(dec.planned_wheels_mps, want.astype(float))
    assert (dec.v_right_mps, dec.v_left_mps) == tuple(dec.planned_wheels_mps[0]) and dec.forecasts
    # the exported graph is the trained map on every step
    assert np.max(np.abs(pol.network(X[:64]) - np.clip(m.predict(X[:64]), -0.8, 0.8))) <= 1e-5
    start, n, w = LAY.set_slots
    Xp = X.copy()
    rng = np.random.default_rng(1)
    for i in range(len(X)):
        Xp[i, start:start + n * w] = X[i, start:start + n * w].reshape(n, w)[rng.permutation(n)].ravel()
    assert np.max(np.abs(pol.network(X) - pol.network(Xp))) <= 1e-6


def test_a_plan_network_runs_behind_the_check_with_its_previous_plan(plan_model):
    from gpcnav.controllers import make_controller
    path, _, _, _ = plan_model
    ctl = make_controller("nn", CFG, RobotParams(), path, "on")
    assert isinstance(ctl, Shield) and ctl.previous_plan and ctl.trust_plans
    for k in range(3):
        dec = ctl.decide(_walkers(k))
        assert math.isfinite(dec.v_right_mps) and dec.planned_wheels_mps.shape == (H, 2)
    assert "shield_previous_plan_used" in ctl.counters


def test_plan_networks_are_refused_where_they_cannot_run(plan_model, tmp_path):
    """Two passes, an export for two passes, and a file whose output width is not what its
    metadata say: each a one-line ValueError."""
    import onnx
    from nn_export import OnnxPolicy
    from nn_export.training.export import export_onnx
    path, X, _, folder = plan_model
    with pytest.raises(ValueError, match="one pass"):
        OnnxPolicy(path, preset="improved", two_pass=True)
    with pytest.raises(ValueError, match="--passes 1"):
        export_onnx(folder, tmp_path / "two.onnx", X[:16], decision_passes=2)
    proto = onnx.load(str(path))
    for p in proto.metadata_props:
        if p.key == "output":
            p.value = "command"
    onnx.save(proto, str(tmp_path / "liar.onnx"))
    with pytest.raises(ValueError, match=r"shape \[batch, 2\]"):
        OnnxPolicy(tmp_path / "liar.onnx", preset="improved")


@pytest.mark.slow  # kept out of the default suite for its time (CI: under 10 minutes)
def test_the_plan_target_reads_the_datasets_plans(plan_model, tmp_path):
    """``load_dataset(..., target="plan")``: the (n, 2 H) rows of the plans, whose first
    step is the label, also of a DAgger round a plan network drove; an odd number of outputs
    cannot take the speed/turn basis."""
    from nn_export.training.dataset import load_dataset
    from nn_export.training.dataset.shards import TARGETS  # noqa: F401 (the public name)
    from nn_export.training.train import WheelSpeedMLP
    import subprocess
    import sys
    d = tmp_path / "ds"
    for args in (("--samples", "20", "--layout", "set"),
                 ("--dagger", plan_model[0], "--dagger-suite", "circle-crossing", "--movers", "3", "--episodes", "1",
                  "--round", "1")):
        proc = subprocess.run([sys.executable, "-m", "gpcnav", "dataset", "--out", str(d), "--preset", "improved",
                               "--workers", "1", *map(str, args)], capture_output=True, text=True, timeout=400)
        assert proc.returncode == 0, proc.stderr[-2000:]
    assert load_dataset(d, ("dagger1",), target="plan").Y.shape[1] == 2 * H
    one, plan = load_dataset(d), load_dataset(d, target="plan")
    assert plan.Y.shape == (len(one.Y), 2 * H)
    np.testing.assert_array_equal(plan.Y[:, :2], one.Y)
    with pytest.raises(ValueError, match="target"):
        load_dataset(d, target="path")
    with pytest.raises(ValueError, match="even number"):
        WheelSpeedMLP(max_epochs=1).fit(one.X, plan.Y[:, :3])
