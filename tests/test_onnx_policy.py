"""OnnxPolicy: load-time refusal of bad or mismatched model files, the two-pass scheme checked
against an independent re-computation, the shipped models, and a model retrained from
scratch through the command line."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace

import numpy as np
import pytest

from casadi_gpc.config import preset
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState, robot_step
from casadi_gpc.types import Observation, ObstacleMeasurement, StaticObstacle
from nn_export.runtime.features import compute_features
from nn_export.runtime.layouts import layout_for
from nn_export.runtime.situation import reference_poses
from nn_export.runtime.policy import POLICY_FORMAT, OnnxPolicy, shipped_model_path

torch = pytest.importorskip("torch")
onnx = pytest.importorskip("onnx")


def _model(tmp_path, preset_name="paper", layout="paper", robot=None, name="m", seed=0):
    """A small network with real provenance, trained on synthetic data (fast)."""
    from nn_export.training.export import POLICY_FORMAT as EXPORT_FORMAT, export_onnx
    from nn_export.training.train import WheelSpeedMLP
    assert EXPORT_FORMAT == POLICY_FORMAT
    cfg = preset(preset_name)
    lay = layout_for(layout, cfg.horizon)
    robot = robot or RobotParams()
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(300, lay.size))
    Y = 0.3 * np.tanh(X[:, :2]) + 0.3
    m = WheelSpeedMLP(hidden=8, max_epochs=30, random_state=seed).fit(X, Y, feature_names=lay.feature_names)
    m.save(tmp_path / name, {
        "preset": cfg.name, "horizon": cfg.horizon, "sample_time_s": cfg.sample_time_s, "planner_config": cfg.to_dict(),
        "robot": robot.to_dict(), "feature_layout": lay.name, "feature_layout_version": lay.version,
        "feature_layout_spec": lay.to_dict(), "dataset": {"id": "synthetic"}})
    path = tmp_path / f"{name}.onnx"
    export_onnx(tmp_path / name, path)
    return path


@pytest.fixture(scope="module")
def paper_model(tmp_path_factory):
    return _model(tmp_path_factory.mktemp("models"))


def _edit_metadata(src, dst, **changes):
    proto = onnx.load(src)
    meta = {p.key: p.value for p in proto.metadata_props}
    meta.update({k: v for k, v in changes.items() if v is not None})
    for k in [k for k, v in changes.items() if v is None]:
        meta.pop(k)
    del proto.metadata_props[:]
    for k, v in meta.items():
        proto.metadata_props.add(key=k, value=v)
    onnx.save(proto, dst)
    return dst


def _one_line_refusal(exc_info, path):
    msg = str(exc_info.value)
    assert "\n" not in msg and str(path) in msg
    return msg


# --- load-time checks ---------------------------------------------------------------------
def test_loads_and_reports_metadata(paper_model):
    p = OnnxPolicy(paper_model, preset="paper")
    assert p.sample_time_s == 1.5 and p.horizon == 6
    info = p.model_info
    assert info["preset"] == "paper" and info["feature_layout"] == "paper" and info["n_features"] == 17
    assert info["dataset"] == {"id": "synthetic"} and len(info["sha256"]) == 64
    assert OnnxPolicy(paper_model).config.name == "paper"  # preset from the file


def test_missing_file(tmp_path):
    with pytest.raises(FileNotFoundError) as e:
        OnnxPolicy(tmp_path / "nope.onnx")
    _one_line_refusal(e, tmp_path / "nope.onnx")


def _bad_utf8_in_metadata(data: bytes) -> bytes:
    """The file with one byte of its metadata's JSON no longer UTF-8 (the graph still loads)."""
    b = bytearray(data)
    b[b.find(b'{"') + 5] = 0xFF
    return bytes(b)


@pytest.mark.parametrize("damage", ["truncated", "garbage", "empty", "flipped", "metadata"])
def test_damaged_files_are_refused_at_load_time(paper_model, tmp_path, damage):
    data = paper_model.read_bytes()
    bad = {"truncated": data[: len(data) // 2], "garbage": b"not an onnx model at all" * 10, "empty": b"",
           "flipped": data[:40] + bytes(b ^ 0xFF for b in data[40:400]) + data[400:],
           "metadata": _bad_utf8_in_metadata(data) if damage == "metadata" else b""}[damage]
    path = tmp_path / f"{damage}.onnx"
    path.write_bytes(bad)
    with pytest.raises(ValueError) as e:
        OnnxPolicy(path, preset="paper")
    _one_line_refusal(e, path)


@pytest.mark.parametrize("changes, match", [
    ({"format": "something-else/1"}, "not a gpcnav policy model"),
    ({"preset": "improved"}, "H=6"),
    ({"feature_layout_version": "99", "feature_layout_spec": None}, "version 99"),
    ({"n_features": "18"}, "18"),
    ({"horizon": "7", "feature_layout_spec": None}, "horizon|H=7|inputs|feature names"),
    ({"robot": json.dumps({**RobotParams().to_dict(), "wheel_base_m": 0.6})}, "another robot"),
    ({"dataset": None}, "lacks dataset"),
    ({"robot": "{not json"}, "malformed"),
])
def test_mismatched_metadata_is_refused(paper_model, tmp_path, changes, match):
    path = _edit_metadata(paper_model, tmp_path / "edited.onnx", **changes)
    with pytest.raises(ValueError, match=match) as e:
        OnnxPolicy(path)
    _one_line_refusal(e, path)


def test_a_preset_that_is_none_is_said_so():
    """OnnxPolicy(preset="imroved") said no model file .../imroved.onnx existed (a FileNotFoundError),
    as if the package had lost one."""
    with pytest.raises(ValueError, match=r"^unknown preset 'imroved' \(choose from paper, improved\)$"):
        OnnxPolicy(preset="imroved")


@pytest.mark.parametrize("kw, words", [
    # a negative distance was taken (the second pass never ran); NaN and infinity were refused already
    (dict(safety_distance_m=-1), r"^safety_distance_m must be a finite number, not negative, got -1$"),
    (dict(safety_distance_m=math.nan), r"^safety_distance_m must be a finite number, not negative, got nan$"),
    (dict(safety_distance_m=math.inf), r"^safety_distance_m must be a finite number, not negative, got inf$"),
    # "abc" failed inside float() ("could not convert string to float"), naming no argument;
    # "0.3" and True were taken as 0.3 m and 1.0 m (the rule of RobotParams and EKFSettings: a real number)
    (dict(safety_distance_m="abc"), r"^safety_distance_m must be a finite number, not negative, got 'abc'$"),
    (dict(safety_distance_m="0.3"), r"^safety_distance_m must be a finite number, not negative, got '0.3'$"),
    (dict(safety_distance_m=True), r"^safety_distance_m must be a finite number, not negative, got True$"),
    (dict(safety_distance_m=[1.0]), r"^safety_distance_m must be a finite number, not negative, got \[1.0\]$"),
    (dict(check_forecast="curved"), r"^check_forecast must be 'turn' or 'straight'"),
])
def test_a_bad_keyword_argument_is_a_value_error_naming_it(kw, words):
    with pytest.raises(ValueError, match=words):
        OnnxPolicy(**kw)
    assert OnnxPolicy(safety_distance_m=0).safety_distance_m == 0.0  # 0: a second pass only on a predicted overlap
    assert OnnxPolicy(safety_distance_m=np.float32(0.5)).safety_distance_m == 0.5  # numpy's numbers are numbers


@pytest.mark.parametrize("field, value", [("measurement_std_m", -0.02), ("speed_noise_mps2", math.nan),
                                          ("initial_speed_std_mps", math.inf), ("gate_chi2", 0.0),
                                          ("max_maneuver_mps", -1.0), ("max_rejections", 2.5)])
def test_filter_settings_that_are_no_noise_level_are_refused(field, value):
    """EKFSettings (OnnxPolicy's ekf_settings, the planner's filters) took any number: a negative
    or NaN noise level made the filter's covariances nonsense, with no word."""
    from casadi_gpc.estimation.ekf import EKFSettings
    with pytest.raises(ValueError, match=f"^EKFSettings.{field} must be "):
        EKFSettings(**{field: value})
    assert EKFSettings(measurement_std_m=0.0, max_rejections=0).measurement_std_m == 0.0


def test_never_runs_under_another_preset(paper_model):
    with pytest.raises(ValueError, match="trained for preset 'paper', refusing .* 'improved'") as e:
        OnnxPolicy(paper_model, preset="improved")
    _one_line_refusal(e, paper_model)


def test_another_robot_is_refused(paper_model):
    with pytest.raises(ValueError, match="another robot"):
        OnnxPolicy(paper_model, robot=RobotParams(max_wheel_speed_mps=1.0))


def test_a_foreign_onnx_graph_is_refused(tmp_path):
    from onnx import TensorProto, helper
    g = helper.make_graph([helper.make_node("Identity", ["features"], ["wheel_speeds_mps"])], "g",
                          [helper.make_tensor_value_info("features", TensorProto.FLOAT, [None, 17])],
                          [helper.make_tensor_value_info("wheel_speeds_mps", TensorProto.FLOAT, [None, 17])])
    path = tmp_path / "foreign.onnx"
    onnx.save(helper.make_model(g, opset_imports=[helper.make_opsetid("", 17)], ir_version=8), path)
    with pytest.raises(ValueError, match="not a gpcnav policy model"):
        OnnxPolicy(path)


def test_cli_refuses_a_mismatched_model_with_exit_2(paper_model, tmp_path):
    out = subprocess.run([sys.executable, "-m", "gpcnav", "simulate", "scenarios/paper/fig7_1_head_on.toml",
                          "--controller", "nn", "--model", str(paper_model), "--preset", "improved"],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2
    assert len(out.stderr.strip().splitlines()) == 1 and "refusing" in out.stderr


# --- the two passes, against an independent re-computation --------------------------------
def _obs(t, robot, obstacle_xy=None, statics=()):
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(8.0), Segment.arc(4.0, 0.6), Segment.line(6.0)), 0.4)
    moving = () if obstacle_xy is None else (ObstacleMeasurement(0, obstacle_xy, 0.3),)
    return Observation(t, robot, ref, moving, statics)


def _net(policy, f):
    return policy.network(f[None, :])[0].astype(float)


def _free_rollout(policy, obs):
    """Pass 1 written out again: features of the obstacle-free situation at each predicted
    state against the desired poses from that step on; the robot model in between."""
    cfg, lay = policy.config, policy.layout
    H, T = cfg.horizon, cfg.sample_time_s
    s_m = policy.tracker.clock.s_m  # the clock after this sample's update
    ref = reference_poses(obs.reference, s_m, T, 2 * H - 1)
    r = obs.robot
    state = [r.x_m, r.y_m, r.heading_rad, r.v_right_mps, r.v_left_mps]
    poses, wheels = [], []
    from nn_export.runtime.situation import Situation
    for j in range(H):
        sit = Situation(RobotState(*state), ref[j:j + H + 1], T, obs.reference.speed_mps)
        w = _net(policy, compute_features(lay, sit))
        x, y, th = robot_step(np, state[0], state[1], state[2], w[0], w[1], T, policy.robot.wheel_base_m)
        state = [float(x), float(y), float(th), float(w[0]), float(w[1])]
        poses.append(state[:3])
        wheels.append(w)
    return np.array(poses), np.array(wheels)


def test_pass_one_is_the_networks_free_rollout(paper_model):
    p = OnnxPolicy(paper_model)
    p.safety_distance_m = -1e9  # never a second pass (the constructor refuses a negative distance: set past it)
    obs = _obs(3.0, RobotState(1.0, 0.2, 0.1, 0.3, 0.35), obstacle_xy=(4.0, 0.0))
    d = p.decide(obs)
    poses, wheels = _free_rollout(p, obs)
    np.testing.assert_allclose(d.planned_poses, poses, atol=1e-6)
    np.testing.assert_allclose(d.planned_wheels_mps, wheels, atol=1e-6)
    assert (d.v_right_mps, d.v_left_mps) == pytest.approx(tuple(wheels[0]), abs=1e-6)
    assert p.counters["second_pass"] == 0


def test_pass_two_follows_the_predicted_path_with_the_obstacle(paper_model):
    p = OnnxPolicy(paper_model, safety_distance_m=1e9)  # always a second pass
    robot = RobotState(1.0, 0.2, 0.1, 0.3, 0.35)
    obs = _obs(3.0, robot, obstacle_xy=(4.0, 0.0), statics=(StaticObstacle((3.0, 1.5), 0.3),))
    d = p.decide(obs)
    poses, _ = _free_rollout(p, obs)
    sit = p.tracker.update.__self__  # the tracker after this sample (its state is what decide used)
    assert sit is p.tracker
    # the situation decide saw, rebuilt: same tracks (one EKF step), the predicted poses as reference
    q = OnnxPolicy(paper_model)
    situation = q.tracker.update(obs)
    desired = np.vstack([[robot.x_m, robot.y_m, robot.heading_rad], poses])
    w = _net(p, compute_features(p.layout, situation.with_reference(desired)))
    assert (d.v_right_mps, d.v_left_mps) == pytest.approx(tuple(w), abs=1e-6)
    assert p.counters["second_pass"] == 1 and d.reason.startswith("pass 2")


def test_one_pass_variant_uses_the_real_reference_and_the_obstacles(paper_model):
    p = OnnxPolicy(paper_model, two_pass=False)
    obs = _obs(1.5, RobotState(0.5, -0.1, 0.0, 0.2, 0.2), obstacle_xy=(5.0, 0.5))
    d = p.decide(obs)
    q = OnnxPolicy(paper_model)
    w = _net(p, compute_features(p.layout, q.tracker.update(obs)))
    assert (d.v_right_mps, d.v_left_mps) == pytest.approx(tuple(w), abs=1e-6)


def test_second_pass_triggers_on_the_predicted_clearance(paper_model):
    p = OnnxPolicy(paper_model, safety_distance_m=0.5)
    robot = RobotState(0.0, 0.0, 0.0, 0.3, 0.3)
    far = p.decide(_obs(0.0, robot, obstacle_xy=(0.0, 30.0)))  # far away: one pass is enough
    assert far.reason.startswith("pass 1") and p.counters["second_pass"] == 0
    p.reset()  # a fresh track: a jump of the same obstacle would be gated as an outlier
    near = p.decide(_obs(0.0, robot, obstacle_xy=(float(far.planned_poses[2, 0]), float(far.planned_poses[2, 1]))))
    assert near.reason.startswith("pass 2") and p.counters["second_pass"] == 1
    assert near.info["predicted_clearance_m"] < 0.5


# --- the shipped models --------------------------------------------------------------------
@pytest.mark.parametrize("name", ["paper", "improved"])
def test_shipped_model_matches_its_preset(name):
    path = shipped_model_path(name)
    if not path.is_file():
        pytest.skip("model not shipped yet")
    p = OnnxPolicy(preset=name)
    cfg = preset(name)
    assert p.model_info["preset"] == name and p.sample_time_s == cfg.sample_time_s and p.horizon == cfg.horizon
    assert p.model_info["feature_layout"] == "paper" and p.model_info["n_features"] == 11 + cfg.horizon
    assert path.stat().st_size < 64_000  # three hidden layers of 64 in float32 plus metadata: ~45 KB
    other = "improved" if name == "paper" else "paper"
    with pytest.raises(ValueError, match="refusing"):
        OnnxPolicy(path, preset=other)


def test_the_shipped_model_named_by_its_path_keeps_its_crowd_and_walls_networks(tmp_path):
    """``--model`` (or navground's ``model``) naming the shipped file, or a copy of it elsewhere,
    is the shipped model: the same crowd and walls networks answer beside it, the same decisions
    (named, it used to run alone and froze in front of a pillar its layout has no slot for); a
    model of other bytes runs alone."""
    path = shipped_model_path("improved")
    if not path.is_file():
        pytest.skip("model not shipped yet")
    copy = tmp_path / "mine.onnx"
    copy.write_bytes(path.read_bytes())
    default = OnnxPolicy(preset="improved")
    assert "crowd_model" in default.model_info and "walls_model" in default.model_info
    for named in (OnnxPolicy(path, preset="improved"), OnnxPolicy(copy, preset="improved")):
        for key in ("crowd_model", "walls_model"):
            assert named.model_info[key]["sha256"] == default.model_info[key]["sha256"]
    cfg = preset("improved")
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(10.0),), 0.4)
    obs = Observation(0.0, RobotState(0.0, 0.0, 0.0, 0.2, 0.2), ref, (),
                      (StaticObstacle((1.5, 0.05), 0.3), StaticObstacle((2.5, -0.6), 0.3)))
    named = OnnxPolicy(copy, preset="improved")
    a, b = default.decide(obs), named.decide(obs)
    assert (a.v_right_mps, a.v_left_mps, a.reason) == (b.v_right_mps, b.v_left_mps, b.reason)
    assert a.reason == "one pass: crowd network"  # two discs: beyond the main model's static slots
    other = _model(tmp_path, preset_name="improved", name="other")
    assert "crowd_model" not in OnnxPolicy(other, preset="improved").model_info
    assert cfg.sample_time_s == named.sample_time_s


def test_default_policy_is_the_improved_preset():
    if not shipped_model_path("improved").is_file():
        pytest.skip("model not shipped yet")
    assert OnnxPolicy().config.name == "improved"


# --- a small model retrained from scratch through the command line ------------------------
@pytest.mark.slow  # kept out of the default suite for its time (CI: under 10 minutes)
def test_retrain_a_small_model_from_scratch(tmp_path):
    """dataset -> train -> export -> OnnxPolicy, all through ``gpcnav``, on a tiny dataset:
    the exported network must reproduce the torch model, fit its training labels well below
    their spread, and drive the robot along an obstacle-free line."""
    def gpcnav(*args):
        out = subprocess.run([sys.executable, "-m", "gpcnav", *map(str, args)], capture_output=True, text=True,
                             timeout=600)
        assert out.returncode == 0, out.stderr[-2000:]
        return out.stdout

    gpcnav("dataset", "--out", tmp_path / "data", "--samples", 600, "--preset", "paper", "--workers", 1, "--seed", 3,
           "--shard-size", 300, "--mirror-check-every", 0)
    gpcnav("train", tmp_path / "data", "--out", tmp_path / "model", "--preset", "paper", "--hidden", 16,
           "--epochs", 300, "--seed", 0)
    out = gpcnav("export", tmp_path / "model", "--out", tmp_path / "m.onnx")
    assert "parity" in out
    for name in ("training_curve.json", "training_curve.png", "model.json", "weights.npz"):
        assert (tmp_path / "model" / name).is_file()
    from nn_export.training.dataset import load_dataset
    from nn_export.training.train import WheelSpeedMLP
    data = load_dataset(tmp_path / "data")
    m = WheelSpeedMLP.load(tmp_path / "model")
    p = OnnxPolicy(tmp_path / "m.onnx", preset="paper")
    got = p.network(data.X)
    np.testing.assert_allclose(got, np.clip(m.predict(data.X), -0.8, 0.8), atol=1e-5)
    tr = np.setdiff1d(np.arange(len(data.X)), m.validation_indices_)
    rmse = float(np.sqrt(np.mean((got[tr] - data.Y[tr]) ** 2)))
    # well below the constant predictor (whose RMSE is the labels' spread), with 600 samples
    assert rmse < 0.75 * float(np.std(data.Y)), (rmse, float(np.std(data.Y)))
    # closed loop on an obstacle-free straight line: it moves along the path towards the goal
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(6.0),), 0.3)
    state = RobotState(0.0, 0.0, 0.0)
    for k in range(10):
        d = p.decide(Observation(k * 1.5, state, ref))
        x, y, th = robot_step(np, state.x_m, state.y_m, state.heading_rad, d.v_right_mps, d.v_left_mps, 1.5, 0.5)
        state = RobotState(float(x), float(y), float(th), d.v_right_mps, d.v_left_mps)
    assert 3.0 < state.x_m < 7.0 and abs(state.y_m) < 0.5, state


# --- the bench's network rows compute the same function as onnxruntime -------------------
def test_graph_forward_numpy_and_torch_match_onnxruntime(paper_model):
    from nn_export.training.bench_rows import graph_forward
    p = OnnxPolicy(paper_model)
    X = np.random.default_rng(0).normal(size=(64, p.layout.size)).astype(np.float32) * 3
    ref = p.network(X)
    proto = onnx.load(paper_model)
    np.testing.assert_allclose(graph_forward(proto, "numpy")(X), ref, atol=1e-6)
    with torch.no_grad():
        np.testing.assert_allclose(graph_forward(proto, "torch")(X).numpy(), ref, atol=1e-6)


def test_the_number_of_passes_comes_from_the_model_file_unless_asked(tmp_path):
    """metadata decision_passes: '1' -> one pass, '2' or absent -> the paper's two passes; the
    caller's two_pass wins; anything else is refused at load time with one line."""
    from synthetic_models import tracker_model
    one = tracker_model(tmp_path / "one.onnx", "paper", decision_passes="1")
    two = tracker_model(tmp_path / "two.onnx", "paper", decision_passes="2")
    plain = tracker_model(tmp_path / "plain.onnx", "paper")
    assert OnnxPolicy(one).two_pass is False
    assert OnnxPolicy(two).two_pass is True
    assert OnnxPolicy(plain).two_pass is True
    assert OnnxPolicy(one, two_pass=True).two_pass is True
    bad = tracker_model(tmp_path / "bad.onnx", "paper", decision_passes="3")
    with pytest.raises(ValueError, match="decision_passes") as err:
        OnnxPolicy(bad)
    assert len(str(err.value).splitlines()) == 1
    # one pass really runs one network call per decision, two passes more when an obstacle is near
    from casadi_gpc.types import ObstacleMeasurement
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(10.0),), 0.4)
    calls = {}
    for name, path in (("one", one), ("two", two)):
        p = OnnxPolicy(path)
        n = 0
        orig = p._run

        def counted():
            nonlocal n
            n += 1
            orig()
        p._run = counted
        for k in range(3):
            p.decide(Observation(1.5 * k, RobotState(0.6 * k, 0.0, 0.0), ref,
                                 (ObstacleMeasurement(0, (3.0 - 0.3 * k, 0.0), 0.3),)))
        calls[name] = n
    assert calls["one"] == 3 and calls["two"] > 3 * 6


def test_the_one_pass_decision_is_what_the_constructor_makes(paper_model):
    """The policy makes its one-pass ControlDecision without the frozen dataclass's own
    __init__ (measured 3-4 us of a 30 us decision): every field must equal the
    constructor's, the defaults included, and the default factories must run afresh (its
    ``info`` then holds the decision's timings alone)."""
    from dataclasses import fields
    from casadi_gpc.types import ControlDecision
    p = OnnxPolicy(paper_model, two_pass=False)
    obs = _obs(1.5, RobotState(0.5, -0.1, 0.0, 0.2, 0.2), obstacle_xy=(5.0, 0.5))
    d = p.decide(obs)
    want = ControlDecision(d.v_right_mps, d.v_left_mps, False, "one pass", forecasts=d.forecasts)
    assert type(d) is ControlDecision
    for f in fields(ControlDecision):
        if f.name == "info":  # the decision's own timings, below
            continue
        a, b = getattr(d, f.name), getattr(want, f.name)
        assert a is b or a == b or (a != a and b != b), f.name
    assert want.info == {} and set(d.info) == {"estimation_time_s", "network_time_s"}
    later = replace(obs, t_s=obs.t_s + p.sample_time_s)  # the next sample
    assert all(v > 0 for v in d.info.values()) and d.info is not p.decide(later).info  # a new dict each time
    with pytest.raises(AttributeError):  # still frozen
        d.v_right_mps = 0.0


def test_bench_network_rows_time_the_calls_the_policy_makes(paper_model):
    """forward_rows replays the recorded observations through the policy and times its own
    network calls: one per one-pass decision and round, for each backend, the numpy and
    torch forward passes swapped in; their outputs match onnxruntime's; the recorder keeps
    the observations only (nothing else inside the timed decision)."""
    from nn_export.training.bench_rows import ObservationRecorder, forward_rows, network_inputs, network_summary
    model = _edit_metadata(paper_model, paper_model.with_name("one_pass.onnx"), decision_passes="1")
    rec = ObservationRecorder(OnnxPolicy(model))
    rec.reset()
    last = []
    for k in range(4):
        rec.decide(_obs(1.5 * k, RobotState(0.5 + 0.5 * k, -0.1, 0.0, 0.2, 0.2), obstacle_xy=(5.0 - 0.4 * k, 0.5)))
        last.append(rec.policy._x[0].copy())
    assert len(rec.observations) == 4 and vars(rec).keys() == {"policy", "sample_time_s", "observations"}
    np.testing.assert_array_equal(network_inputs(OnnxPolicy(model), rec.observations), np.array(last))
    rows = forward_rows(model, rec.observations, rounds=3)
    by_name = {r["name"]: r for r in rows}
    assert set(by_name) == {"onnxruntime", "nn-numpy", "nn-torch"}
    for r in rows:
        assert r["problems"] == 4 * 3 and r["time_s"]["median"] > 0.0
        assert r["max_abs_diff_to_onnxruntime_mps"] <= 1e-6
    assert by_name["onnxruntime"]["back_to_back_time_s"]["count"] == 4 * 3
    assert network_summary(rows).startswith("network: the onnxruntime call inside the policy's decisions")


def test_bench_network_rows_beside_walls_are_said_not_timed_as_zero():
    """Beside walls every decision of the shipped policy goes to its walls network, so the
    main network's call rows time nothing: forward_rows makes no rows (they were rows of
    0.000 ms over no call, `gpcnav bench` of a corridor file) and unmeasured_reason says why."""
    from nn_export.training.bench_rows import ObservationRecorder, forward_rows, unmeasured_reason
    from scenarios import Suite
    from scenarios.simulator import simulate
    scenario = Suite("corridor", 1, 901).scenario(0)
    robot = replace(scenario.robot, radius_m=0.25)
    scenario = replace(scenario, robot=robot)
    rec = ObservationRecorder(OnnxPolicy(robot=robot))
    simulate(scenario, rec)
    observations = rec.observations[:12]
    assert len(observations) == 12
    path = rec.policy.model_info["path"]
    assert forward_rows(path, observations, rounds=1, robot=robot) == []
    reason = unmeasured_reason(path, observations, robot)
    assert "not measured" in reason and "the walls network 12" in reason


def test_wheel_speeds_reported_beyond_the_limits_are_held_to_them_as_the_planner_holds_them():
    """A glitching encoder (5 m/s, -3 m/s): the bare network read those speeds into its features and
    roll-out, far outside what it was trained on, and answered otherwise than behind its check layer,
    which holds them (as the GPC does). Now the policy holds them itself, counted in
    ``wheel_state_held``: the same decision as from the limits."""
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(8.0),), 0.4)
    answers = {}
    for wheels in ((5.0, -3.0), (0.8, -0.8)):
        pol = OnnxPolicy()
        pol.reset()
        out = []
        for k in range(3):
            obs = Observation(0.5 * k, RobotState(0.2 * k, 0.0, 0.0, *wheels), ref,
                              (ObstacleMeasurement(1, (5.0 - 0.2 * k, 0.1), 0.3),))
            d = pol.decide(obs)
            out.append((d.v_right_mps, d.v_left_mps))
        answers[wheels] = out, pol.counters.get("wheel_state_held", 0)
    assert answers[(5.0, -3.0)] == (answers[(0.8, -0.8)][0], 3)
    assert answers[(0.8, -0.8)][1] == 0
