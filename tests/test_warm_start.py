"""Training a shipped set network further (``gpcnav train --init``): the network read back from its
ONNX file answers as onnxruntime runs the file; trained further from it, the curve starts at its
error and moves its answers towards the new labels; a network of another shape, layout or kind is
refused in one line (exit 2)."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from casadi_gpc.config import preset
from nn_export.runtime.layouts import layout_for
from nn_export.runtime.policy import shipped_crowd_model_path, shipped_model_path

torch = pytest.importorskip("torch")
pytest.importorskip("onnx")
ort = pytest.importorskip("onnxruntime")

CFG = preset("improved")
LAY = layout_for("set", CFG.horizon)
CROWD = shipped_crowd_model_path("improved")


def _rows(n, seed=0):
    """Rows of the set layout: standard-normal inputs, wheel speeds within the limits, a random number of
    present obstacles in random slots (the others zero)."""
    rng = np.random.default_rng(seed)
    start, k, w = LAY.set_slots
    X = rng.normal(size=(n, LAY.size))
    X[:, :2] = rng.uniform(-0.6, 0.6, (n, 2))
    slots = X[:, start:start + k * w].reshape(n, k, w)
    slots[..., 0] = rng.random((n, k)) < rng.random((n, 1))
    slots[slots[..., 0] == 0.0] = 0.0
    X[:, start:start + k * w] = slots.reshape(n, -1)
    return X


def _onnx(path, X):
    sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    return sess.run(None, {sess.get_inputs()[0].name: X.astype(np.float32)})[0].astype(np.float64)


def _trainer(**kw):
    from nn_export.training.train import WheelSpeedMLP
    return WheelSpeedMLP(hidden=64, layers=2, architecture="set", encoder_width=32, optimizer="adam", relative=True,
                         random_state=0, **kw)


def _read_back(path):
    """The set network of ``path`` read back, as a torch map of rows to wheel speeds (unclipped)."""
    from nn_export.training.set_net import SetNet
    from nn_export.training.train import _ACTIVATIONS
    from nn_export.training.warm_start import read_set_network
    got = read_set_network(path)
    net = SetNet(LAY.size, LAY.set_slots, got["hidden"], 2, _ACTIVATIONS[got["activation"]], got["layers"],
                 got["encoder_width"]).double()
    net.load_state_dict({k: torch.from_numpy(v) for k, v in got["state"].items()})

    def wheels(X):
        with torch.no_grad():
            return (net(torch.from_numpy(X)) + torch.from_numpy(X[:, :2])).numpy()
    return got, wheels


def test_the_network_read_back_answers_as_its_file():
    got, wheels = _read_back(CROWD)
    assert (got["hidden"], got["layers"], got["encoder_width"], got["activation"]) == (64, 2, 32, "tanh")
    assert got["layout"] == "set" and tuple(got["feature_names"]) == LAY.feature_names
    X = _rows(300)
    want = _onnx(CROWD, X)
    inside = np.all(np.abs(want) < 0.79, axis=1)  # the file clips to the wheel limit; the net read back does not
    assert inside.sum() > 100
    np.testing.assert_allclose(wheels(X)[inside], want[inside], atol=2e-5)


def test_trained_further_it_starts_where_the_file_is_and_moves_towards_the_new_labels():
    got, wheels = _read_back(CROWD)
    X = _rows(400, seed=1)
    before = wheels(X)
    Y = before + 0.1  # new labels: 0.1 m/s faster on both wheels
    m = _trainer(max_epochs=8, patience=8, learning_rate=1e-3).fit(X, Y, feature_names=LAY.feature_names,
                                                                   init_state=got["state"])
    val = m.validation_indices_
    assert m.curve_["val_mse"][0] == pytest.approx(0.01, rel=1e-6)  # epoch 0: the file's network, 0.1 m/s off
    assert m.validation_mse_ < 0.25 * m.curve_["val_mse"][0]
    assert np.median(m.predict(X[val]) - before[val]) > 0.05  # towards the labels
    fresh = _trainer(max_epochs=1, patience=1).fit(X, Y, feature_names=LAY.feature_names)
    assert fresh.curve_["val_mse"][0] > 3 * m.curve_["val_mse"][0]  # fresh weights start elsewhere


def test_weights_of_another_shape_are_refused():
    from nn_export.training.warm_start import read_set_network
    state = read_set_network(CROWD)["state"]
    X = _rows(50)
    from nn_export.training.train import WheelSpeedMLP
    narrow = WheelSpeedMLP(hidden=32, layers=2, architecture="set", encoder_width=32, optimizer="adam", relative=True,
                           max_epochs=1)
    with pytest.raises(ValueError, match="do not fit"):
        narrow.fit(X, X[:, :2], feature_names=LAY.feature_names, init_state=state)
    wheels = _trainer(output_basis="wheels", max_epochs=1)
    with pytest.raises(ValueError, match="output basis"):
        wheels.fit(X, X[:, :2], feature_names=LAY.feature_names, init_state=state)


def test_command_line_init_trains_the_shipped_network_further_and_refuses_others(tmp_path):
    def gpcnav(*argv, rc=0):
        proc = subprocess.run([sys.executable, "-m", "gpcnav", *map(str, argv)], capture_output=True, text=True,
                              timeout=400)
        assert proc.returncode == rc, proc.stderr[-2000:]
        return proc

    d = tmp_path / "ds"
    gpcnav("dataset", "--out", d, "--samples", "40", "--preset", "improved", "--layout", "set", "--workers", "1",
           "--shard-size", "20")
    shape = ("--architecture", "set", "--relative", "--hidden", "64", "--layers", "2", "--encoder-width", "32",
             "--optimizer", "adam")
    gpcnav("train", d, "--out", tmp_path / "m", "--preset", "improved", *shape, "--epochs", "1", "--lr", "1e-9",
           "--init", CROWD)
    gpcnav("export", tmp_path / "m", "--out", tmp_path / "m.onnx", "--passes", "1")
    X = _rows(200, seed=2)
    np.testing.assert_allclose(_onnx(tmp_path / "m.onnx", X), _onnx(CROWD, X), atol=1e-4)  # 1e-9 moved nothing
    import onnx
    meta = {p.key: p.value for p in onnx.load(str(tmp_path / "m.onnx")).metadata_props}
    assert '"init": {"model": "improved-crowd.onnx"' in meta["trained_with"]
    for argv, words in (
            (("--init", CROWD, *shape[:7], "--optimizer", "adam"), "--encoder-width is 32, this training's 64"),
            (("--init", CROWD, *shape[:4], "16", *shape[5:]), "--hidden is 64, this training's 16"),
            (("--init", shipped_model_path("improved"), *shape), "set networks only"),
            (("--init", tmp_path / "none.onnx", *shape), "no such model file"),
            (("--init", d / "manifest.json", *shape), "not a readable ONNX model")):
        err = gpcnav("train", d, "--out", tmp_path / "x", "--preset", "improved", *argv, "--epochs", "1",
                     rc=2).stderr
        assert len(err.strip().splitlines()) == 1 and words in err, err
    walls = CROWD.with_name("improved-walls.onnx")
    err = gpcnav("train", d, "--out", tmp_path / "x", "--preset", "improved", "--init", walls, *shape, "--epochs", "1",
                 rc=2).stderr
    assert len(err.strip().splitlines()) == 1 and "'set-walls' layout, the datasets' is 'set'" in err, err
    assert not (tmp_path / "x").exists()
