"""The set layout and the set network (issue 14): one obstacle slot's inputs against a hand
computation, slot order and empty-slot contents that cannot change the exported network's
answer, the slot structure read from the feature names, and the network run by the deployed
policy."""
from __future__ import annotations

import math

import numpy as np
import pytest

from casadi_gpc.config import preset
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState
from casadi_gpc.types import StaticObstacle
from nn_export.runtime.features import compute_features
from nn_export.runtime.layouts import SET_ELEMENT, layout_for, layout_from_dict
from nn_export.runtime.situation import Situation, TrackEstimate, reference_poses

torch = pytest.importorskip("torch")
pytest.importorskip("onnx")

CFG = preset("improved")
LAY = layout_for("set", CFG.horizon)


def _situation(tracks=(), statics=()):
    """The robot at (1, 2) heading north on a northbound line."""
    T = CFG.sample_time_s
    path = ReferencePath((1.0, 0.0), math.pi / 2, (Segment.line(40.0),), 0.4)
    return Situation(RobotState(1.0, 2.0, math.pi / 2, 0.3, 0.25), reference_poses(path, 2.5, T, CFG.horizon), T, 0.4,
                     tuple(tracks), tuple(statics))


def _track(i, state, std=0.2):
    H = CFG.horizon
    return TrackEstimate(i, 0.3, np.asarray(state, dtype=float), np.eye(5) * 1e-3, np.tile(state[:2], (H, 1)),
                         np.tile(np.eye(2) * std ** 2, (H, 1, 1)))


def test_set_layout_names_size_and_round_trip():
    start, n, w = LAY.set_slots
    assert (start, w) == (2, len(SET_ELEMENT)) and n == LAY.k_moving + LAY.k_static
    assert LAY.size == 2 + n * w + 3 + CFG.horizon + 1
    assert LAY.feature_names[start:start + w] == tuple(f"mov1_{e}" for e in SET_ELEMENT)
    assert layout_from_dict(LAY.to_dict()) == LAY
    with pytest.raises(ValueError, match="no obstacle set"):
        layout_for("multi", 6).set_slots


def test_one_moving_and_one_static_slot_by_hand():
    # 3 m ahead and 1 m to the right of the north-facing robot, going west at 0.5 m/s after
    # this step's turn (theta + dtheta = pi): in the robot's frame it moves to the left (+y)
    mover = _track(4, [2.0, 5.0, 0.5, math.pi - 0.05, 0.05], std=0.2)
    f = dict(zip(LAY.feature_names, compute_features(LAY, _situation([mover], [StaticObstacle((0.0, 2.0), 0.4)]))))
    want = {"present": 1.0, "x_m": 3.0, "y_m": -1.0, "vx_mps": 0.0, "vy_mps": 0.5, "turn_rad": 0.05,
            "radius_m": 0.3, "pos_std_m": 0.2, "moving": 1.0}
    for k, v in want.items():
        assert f[f"mov1_{k}"] == pytest.approx(v, abs=1e-12), k
    # the static obstacle 1 m to the robot's left (west of a north-facing robot)
    want = {"present": 1.0, "x_m": 0.0, "y_m": 1.0, "vx_mps": 0.0, "vy_mps": 0.0, "turn_rad": 0.0, "radius_m": 0.4,
            "pos_std_m": 0.0, "moving": 0.0}
    for k, v in want.items():
        assert f[f"sta1_{k}"] == pytest.approx(v, abs=1e-12), k
    assert all(f[f"mov2_{e}"] == 0.0 for e in SET_ELEMENT)  # an empty slot is all zeros


def test_more_movers_than_slots_keeps_the_nearest_and_counts_the_rest():
    movers = [_track(i, [1.0, 2.0 + 0.5 * (i + 1), 0.2, 0.0, 0.0]) for i in range(LAY.k_moving + 3)]
    rep = {}
    f = compute_features(LAY, _situation(movers[::-1]), report=rep)
    start, n, w = LAY.set_slots
    xs = sorted(f[start + 1:start + LAY.k_moving * w:w])
    assert rep["dropped_moving"] == 3
    assert xs == pytest.approx([0.5 * (i + 1) for i in range(LAY.k_moving)])


def test_slot_structure_is_read_from_the_names_and_refuses_other_layouts():
    from nn_export.training.set_net import slot_structure
    assert slot_structure(LAY.feature_names) == LAY.set_slots
    with pytest.raises(ValueError, match="no obstacle slots"):
        slot_structure(["a", "b"])
    with pytest.raises(ValueError, match="present"):
        slot_structure(layout_for("paper", 6).feature_names)


@pytest.fixture(scope="module")
def set_model(tmp_path_factory):
    """A small set network trained on synthetic labels that depend on the obstacles (the
    nearest one pushes the wheels apart), exported for one pass."""
    from nn_export.training.export import export_onnx
    from nn_export.training.train import WheelSpeedMLP
    rng = np.random.default_rng(0)
    start, n, w = LAY.set_slots
    X = rng.normal(size=(600, LAY.size))
    slots = X[:, start:start + n * w].reshape(-1, n, w)
    k = rng.integers(0, 6, size=len(X))  # present obstacles per row, in random slots
    slots[..., 0] = 0.0
    for i, m in enumerate(k):
        slots[i, rng.permutation(n)[:m], 0] = 1.0
    slots[slots[..., 0] == 0.0] = 0.0
    X[:, start:start + n * w] = slots.reshape(len(X), -1)
    near = np.where(slots[..., 0] > 0, np.hypot(slots[..., 1], slots[..., 2]), 9.0).min(1)
    Y = np.column_stack([0.3 + 0.1 * np.tanh(X[:, 0]) + 0.05 / (1 + near), 0.3 - 0.05 / (1 + near)])
    m = WheelSpeedMLP(hidden=16, layers=2, architecture="set", encoder_width=12, optimizer="adam", max_epochs=20,
                      random_state=0).fit(X, Y, feature_names=LAY.feature_names)
    d = tmp_path_factory.mktemp("set")
    m.save(d / "m", {"preset": CFG.name, "horizon": CFG.horizon, "sample_time_s": CFG.sample_time_s,
                     "planner_config": CFG.to_dict(), "robot": RobotParams().to_dict(), "feature_layout": LAY.name,
                     "feature_layout_version": LAY.version, "feature_layout_spec": LAY.to_dict(),
                     "dataset": {"id": "synthetic"}})
    path = d / "m.onnx"
    export_onnx(d / "m", path, X[:128], decision_passes=1)
    return path, X, m


def test_permuting_the_slots_leaves_the_exported_network_unchanged(set_model):
    from nn_export import OnnxPolicy
    path, X, _ = set_model
    pol = OnnxPolicy(path, preset="improved")
    start, n, w = LAY.set_slots
    rng = np.random.default_rng(1)
    Xp = X.copy()
    for i in range(len(X)):
        Xp[i, start:start + n * w] = X[i, start:start + n * w].reshape(n, w)[rng.permutation(n)].ravel()
    y, yp = pol.network(X), pol.network(Xp)
    assert np.max(np.abs(y - yp)) <= 1e-6
    # the network does read the obstacles: moving the present ones changes the answer
    Xm = X.copy()
    Xm[:, start + 1:start + n * w:w] += 1.5 * (Xm[:, start:start + n * w:w] > 0)
    assert np.max(np.abs(pol.network(Xm) - y)) > 1e-3


def test_empty_slots_hold_nothing_the_network_reads(set_model):
    from nn_export import OnnxPolicy
    path, X, _ = set_model
    pol = OnnxPolicy(path, preset="improved")
    start, n, w = LAY.set_slots
    slots = X[:, start:start + n * w].reshape(-1, n, w).copy()
    junk = np.random.default_rng(2).normal(size=slots.shape) * 5.0
    empty = slots[..., :1] == 0.0
    slots = np.where(empty, np.concatenate([np.zeros_like(junk[..., :1]), junk[..., 1:]], -1), slots)
    Xj = X.copy()
    Xj[:, start:start + n * w] = slots.reshape(len(X), -1)
    assert np.max(np.abs(pol.network(Xj) - pol.network(X))) <= 1e-6


def test_saved_set_model_loads_to_the_same_map(set_model, tmp_path):
    from nn_export.training.train import WheelSpeedMLP
    path, X, m = set_model
    m.save(tmp_path / "again", m.provenance_)
    back = WheelSpeedMLP.load(tmp_path / "again")
    assert back.architecture == "set" and np.array_equal(back.predict(X), m.predict(X))


def test_the_deployed_policy_runs_one_pass_among_movers(set_model):
    from casadi_gpc.types import Observation, ObstacleMeasurement
    from nn_export import OnnxPolicy
    path, _, _ = set_model
    pol = OnnxPolicy(path, preset="improved")
    assert not pol.two_pass and pol.layout.is_set
    T = CFG.sample_time_s
    for k in range(4):
        obs = Observation(k * T, RobotState(0.0, 0.1 * k, math.pi / 2, 0.3, 0.3),
                          ReferencePath((0.0, 0.0), math.pi / 2, (Segment.line(30.0),), 0.4),
                          tuple(ObstacleMeasurement(i, (0.5 * i - 1.0, 3.0 + 0.1 * k), 0.3) for i in range(5)))
        dec = pol.decide(obs)
    assert math.isfinite(dec.v_right_mps) and math.isfinite(dec.v_left_mps) and dec.forecasts


def test_the_set_architecture_is_refused_without_a_set_layout():
    from nn_export.training.train import WheelSpeedMLP
    X = np.random.default_rng(0).normal(size=(50, 17))
    with pytest.raises(ValueError, match="no obstacle slots"):
        WheelSpeedMLP(architecture="set", max_epochs=1).fit(X, X[:, :2], feature_names=[f"x{i}" for i in range(17)])
    with pytest.raises(ValueError, match="needs the feature names"):
        WheelSpeedMLP(architecture="set", max_epochs=1).fit(X, X[:, :2])
    with pytest.raises(ValueError, match="architecture"):
        WheelSpeedMLP(architecture="deep").fit(X, X[:, :2])


@pytest.mark.slow  # about 20 s: the default suite stays under 10 minutes on two cores
def test_command_line_set_data_from_a_crowd_then_the_set_network(tmp_path):
    """``gpcnav dataset --layout set``, an on-policy round on a crowd suite (its walkers fill
    several slots), ``gpcnav train --architecture set`` and ``export --passes 1``; the set
    architecture refused on a dataset of another layout (one line, exit 2)."""
    import subprocess
    import sys

    from nn_export.training.dataset import load_dataset, read_manifest

    def gpcnav(*argv, rc=0):
        proc = subprocess.run([sys.executable, "-m", "gpcnav", *map(str, argv)], capture_output=True, text=True,
                              timeout=400)
        assert proc.returncode == rc, proc.stderr[-2000:]
        return proc

    d = tmp_path / "ds"
    gpcnav("dataset", "--out", d, "--samples", "40", "--preset", "improved", "--layout", "set", "--workers", "1",
           "--shard-size", "20")
    gpcnav("dataset", "--out", d, "--dagger", "gpc", "--dagger-suite", "circle-crossing", "--movers", "3",
           "--behaviour", "social_force", "--episodes", "1", "--round", "1", "--preset", "improved", "--workers", "1")
    part = read_manifest(d)["parts"]["gpc1"]
    assert part["info"]["suite"] == "circle-crossing" and part["info"]["movers"] == 3
    assert part["info"]["behaviour"] == "social_force" and part["samples"] > 0
    ds = load_dataset(d, ("gpc1",))
    start, n, w = LAY.set_slots
    present = ds.X[:, start:start + n * w:w]
    # the three walkers fill three slots (the EKF may hold a second hypothesis of one: more)
    assert present.sum(1).max() >= 3 and set(np.unique(present)) <= {0.0, 1.0}
    gpcnav("train", d, "--out", tmp_path / "m", "--preset", "improved", "--architecture", "set", "--hidden", "8",
           "--encoder-width", "8", "--optimizer", "adam", "--epochs", "2")
    gpcnav("export", tmp_path / "m", "--out", tmp_path / "m.onnx", "--passes", "1")
    from nn_export import OnnxPolicy
    assert OnnxPolicy(tmp_path / "m.onnx", preset="improved").layout.is_set
    p = tmp_path / "paper-ds"
    gpcnav("dataset", "--out", p, "--samples", "20", "--preset", "paper", "--workers", "1", "--shard-size", "20")
    err = gpcnav("train", p, "--out", tmp_path / "x", "--preset", "paper", "--architecture", "set", rc=2).stderr
    assert len(err.strip().splitlines()) == 1 and "--architecture set" in err


def _walkers(n, k, T):
    """The observation of sample ``k``: the robot driving north, ``n`` walkers ahead of it."""
    from casadi_gpc.types import Observation, ObstacleMeasurement
    return Observation(k * T, RobotState(0.0, 0.1 * k, math.pi / 2, 0.3, 0.3),
                       ReferencePath((0.0, 0.0), math.pi / 2, (Segment.line(30.0),), 0.4),
                       tuple(ObstacleMeasurement(i, (0.6 * i - 1.0, 3.0 - 0.05 * k), 0.3) for i in range(n)))


def test_a_one_obstacle_model_hands_crowds_to_the_crowd_network(set_model, tmp_path):
    """With a crowd network, the policy answers with it exactly when more movers are in range
    than its main model's layout holds, and then gives what the crowd network alone gives."""
    from nn_export import OnnxPolicy
    from synthetic_models import tracker_model
    path, _, _ = set_model
    main = tracker_model(tmp_path / "main.onnx", "improved")
    both = OnnxPolicy(main, preset="improved", crowd_model=path)
    alone = OnnxPolicy(path, preset="improved")
    only_main = OnnxPolicy(main, preset="improved")
    T = CFG.sample_time_s
    for n, crowd in ((1, False), (4, True)):
        for p in (both, alone, only_main):
            p.reset()
        for k in range(5):
            obs = _walkers(n, k, T)
            d, a, m = both.decide(obs), alone.decide(obs), only_main.decide(obs)
            want = a if crowd else m
            assert (d.v_right_mps, d.v_left_mps) == (want.v_right_mps, want.v_left_mps)
        assert both.counters["crowd_network"] == (5 if crowd else 0)
    assert both.model_info["crowd_model"]["feature_layout"] == "set"
    assert only_main.counters["crowd_network"] == 0 and "crowd_model" not in only_main.model_info


def test_a_crowd_network_must_be_a_one_pass_set_model(tmp_path):
    from nn_export import OnnxPolicy
    from synthetic_models import tracker_model
    main = tracker_model(tmp_path / "main.onnx", "improved")
    with pytest.raises(ValueError, match="set layout") as exc:
        OnnxPolicy(main, preset="improved", crowd_model=main)
    assert "\n" not in str(exc.value) and str(main) in str(exc.value)
    # a crowd network whose numbers are corrupt is refused at load, as a main model is
    bad = tracker_model(tmp_path / "bad.onnx", "improved", layout_name="set", weight_fill=float("nan"),
                        decision_passes="1")
    with pytest.raises(ValueError, match="non-finite") as exc:
        OnnxPolicy(main, preset="improved", crowd_model=bad)
    assert "\n" not in str(exc.value) and str(bad) in str(exc.value)
