"""The trainer (estimator conventions, normalisation, split, early stopping, reproducibility,
Fig. 6 curve) and the ONNX export (checker, metadata, clip inside the graph, parity)."""
from __future__ import annotations

import json

import numpy as np
import pytest

torch = pytest.importorskip("torch")
onnx = pytest.importorskip("onnx")
ort = pytest.importorskip("onnxruntime")

from nn_export.training.export import INPUT_NAME, POLICY_FORMAT, REQUIRED_METADATA, export_onnx  # noqa: E402
from nn_export.training.train import WheelSpeedMLP  # noqa: E402

PROV = {"preset": "paper", "horizon": 6, "sample_time_s": 1.5, "feature_layout": "paper",
        "feature_layout_version": 1, "robot": {"wheel_base_m": 0.5, "radius_m": 0.35, "max_wheel_speed_mps": 0.8,
                                                "max_wheel_accel_mps2": 0.8},
        "dataset": {"id": "synthetic"}}


def _data(n=1500, seed=0, scale=0.5):
    """A smooth known map from 17 inputs (one constant, like an absent-obstacle code) to 2."""
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n, 17)) * np.linspace(0.1, 3.0, 17) + np.arange(17)
    X[:, 4] = 7.0
    Z = (X - np.arange(17)) / np.linspace(0.1, 3.0, 17)
    Y = scale * np.stack([np.tanh(0.8 * Z[:, 0] - 0.4 * Z[:, 2]), 0.5 * np.tanh(Z[:, 1] + 0.3 * Z[:, 5])], axis=1)
    return X, Y


@pytest.fixture(scope="module")
def fitted():
    X, Y = _data()
    return WheelSpeedMLP(hidden=16, max_epochs=150, batch_size=128, patience=40, random_state=3).fit(X, Y), X, Y


def test_init_only_stores_hyper_parameters():
    m = WheelSpeedMLP(hidden=7, random_state=5)
    assert m.get_params()["hidden"] == 7 and m.get_params()["random_state"] == 5
    assert not [k for k in vars(m) if k.endswith("_")]  # nothing learned before fit
    assert WheelSpeedMLP().hidden == 35  # the paper's network by default
    with pytest.raises(RuntimeError, match="not fitted"):
        m.predict(np.zeros((1, 17)))


@pytest.mark.parametrize("X, Y, match", [
    (np.zeros((20, 17)), np.zeros((19, 2)), "rows"),
    (np.zeros(20), np.zeros((20, 2)), "2-D"),
    (np.full((20, 17), np.nan), np.zeros((20, 2)), "finite"),
    (np.zeros((5, 17)), np.zeros((5, 2)), "at least 10"),
])
def test_fit_validates_arrays(X, Y, match):
    with pytest.raises(ValueError, match=match):
        WheelSpeedMLP(max_epochs=1).fit(X, Y)


@pytest.mark.parametrize("kw", [{"hidden": 0}, {"activation": "cosine"}, {"validation_fraction": 1.0},
                                {"learning_rate": -1.0}, {"patience": 0}, {"weight_decay": -1.0},
                                {"weight_decay": float("nan")}])
def test_fit_validates_hyper_parameters(kw):
    X, Y = _data(50)
    with pytest.raises(ValueError):
        WheelSpeedMLP(max_epochs=1, **kw).fit(X, Y)


@pytest.mark.parametrize("groups", [None, "pairs"])
def test_a_validation_fraction_that_leaves_nothing_to_train_on_is_refused(groups):
    """--validation-fraction 0.999 on 200 situations put all 200 in validation: the training
    split was empty and the training failed as "diverged (learning_rate 0.003)"."""
    X, Y = _data(n=400)
    g = None if groups is None else np.arange(400) // 2
    with pytest.raises(ValueError, match=r"validation fraction 0.999 of (400 samples|200 situations) leaves none"):
        WheelSpeedMLP(max_epochs=1, validation_fraction=0.999).fit(X, Y, groups=g)
    m = WheelSpeedMLP(max_epochs=1, validation_fraction=0.99).fit(X, Y, groups=g)
    assert len(m.train_indices_) > 0


def test_learns_a_known_map_and_keeps_the_best_epoch(fitted):
    m, X, Y = fitted
    # the labels span about +-0.5 m/s; a fitted net must get far below their variance
    assert m.validation_mse_ < 0.02 * Y.var()
    # the kept weights are the best seen on validation, and the curve says so
    assert m.validation_mse_ == pytest.approx(min(m.curve_["val_mse"]), rel=1e-9)
    assert m.curve_["val_mse"][m.best_epoch_] == pytest.approx(m.validation_mse_, rel=1e-9)
    assert len(m.curve_["epoch"]) == len(m.curve_["train_mse"]) == len(m.curve_["val_mse"])
    assert m.curve_["val_mse"][-1] < m.curve_["val_mse"][0] / 10


def test_normalisation_uses_the_training_split_only(fitted):
    m, X, Y = fitted
    p = m.numpy_params()
    tr = m.train_indices_
    np.testing.assert_allclose(p["x_mean"], X[tr].mean(0), rtol=0, atol=1e-12)
    # outputs are learned as (mean speed, half difference), standardised on the training split
    U = np.stack([Y[tr].mean(1), 0.5 * (Y[tr, 0] - Y[tr, 1])], axis=1)
    np.testing.assert_allclose(p["y_mean"], U.mean(0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(p["y_scale"], U.std(0), rtol=1e-12)
    np.testing.assert_array_equal(p["y_mix"], [[1.0, 1.0], [1.0, -1.0]])
    assert p["x_scale"][4] == 1.0  # a constant input is not a division by zero
    assert not np.array_equal(p["x_mean"], X.mean(0))  # the validation rows are left out
    assert len(set(m.train_indices_) & set(m.validation_indices_)) == 0
    assert len(m.train_indices_) + len(m.validation_indices_) == len(X)


def test_groups_stay_on_one_side_of_the_split():
    X, Y = _data(400)
    groups = np.arange(400) // 2  # a situation and its mirror image
    m = WheelSpeedMLP(hidden=4, max_epochs=2).fit(X, Y, groups=groups)
    assert not set(groups[m.train_indices_]) & set(groups[m.validation_indices_])


def test_reproducible_from_the_seed():
    X, Y = _data(300)
    a = WheelSpeedMLP(hidden=8, max_epochs=10, random_state=11).fit(X, Y).numpy_params()
    b = WheelSpeedMLP(hidden=8, max_epochs=10, random_state=11).fit(X, Y).numpy_params()
    c = WheelSpeedMLP(hidden=8, max_epochs=10, random_state=12).fit(X, Y).numpy_params()
    for k in a:
        np.testing.assert_array_equal(a[k], b[k])
    assert not np.array_equal(a["W1"], c["W1"])


def test_early_stopping_stops_when_validation_stalls():
    X, Y = _data(300, seed=1)
    Y = np.random.default_rng(9).normal(size=Y.shape)  # pure noise: nothing to learn
    m = WheelSpeedMLP(hidden=8, max_epochs=2000, patience=10, random_state=0).fit(X, Y)
    assert m.stop_reason_ == "early_stopping"
    assert len(m.curve_["epoch"]) - 1 == m.best_epoch_ + 10


def test_save_load_roundtrip_and_curve_files(fitted, tmp_path):
    m, X, _ = fitted
    m.save(tmp_path / "m", PROV)
    for name in ("weights.npz", "model.json", "training_curve.json", "training_curve.png"):
        assert (tmp_path / "m" / name).is_file()
    curve = json.loads((tmp_path / "m" / "training_curve.json").read_text())
    assert curve["val_mse"] == m.curve_["val_mse"] and curve["n_validation"] == len(m.validation_indices_)
    m2 = WheelSpeedMLP.load(tmp_path / "m")
    np.testing.assert_array_equal(m2.predict(X), m.predict(X))
    assert m2.provenance_["preset"] == "paper"


def test_export_parity_checker_and_metadata(fitted, tmp_path):
    m, X, _ = fitted
    m.save(tmp_path / "m", PROV)
    val = X[m.validation_indices_]
    rep = export_onnx(tmp_path / "m", tmp_path / "m.onnx", val)
    proto = onnx.load(tmp_path / "m.onnx")
    onnx.checker.check_model(proto, full_check=True)
    meta = {p.key: p.value for p in proto.metadata_props}
    assert set(REQUIRED_METADATA) <= set(meta)
    assert meta["format"] == POLICY_FORMAT and meta["preset"] == "paper" and meta["horizon"] == "6"
    assert float(meta["validation_rmse_mps"]) == pytest.approx(np.sqrt(m.validation_mse_))
    assert json.loads(meta["robot"]) == PROV["robot"]
    # independent parity check: onnxruntime on the validation set against the torch model
    sess = ort.InferenceSession(str(tmp_path / "m.onnx"), providers=["CPUExecutionProvider"])
    got = sess.run(None, {INPUT_NAME: val.astype(np.float32)})[0]
    want = np.clip(m.predict(val), -0.8, 0.8)
    assert np.max(np.abs(got - want)) <= 1e-5
    assert rep["parity_max_abs_mps"] <= 1e-5
    assert rep["bytes"] < 20_000  # a few KB


def test_clip_to_the_wheel_limit_is_inside_the_graph(tmp_path):
    X, Y = _data(400, scale=3.0)  # labels up to 3 m/s: the net will exceed the 0.8 m/s limit
    m = WheelSpeedMLP(hidden=8, max_epochs=60, random_state=0).fit(X, Y)
    m.save(tmp_path / "m", PROV)
    export_onnx(tmp_path / "m", tmp_path / "m.onnx")
    sess = ort.InferenceSession(str(tmp_path / "m.onnx"), providers=["CPUExecutionProvider"])
    raw = m.predict(X)
    assert np.abs(raw).max() > 1.5
    got = sess.run(None, {INPUT_NAME: X.astype(np.float32)})[0]
    assert np.abs(got).max() == pytest.approx(0.8, abs=1e-7)
    np.testing.assert_allclose(got, np.clip(raw, -0.8, 0.8), atol=1e-5)


def test_export_refuses_a_model_without_provenance(fitted, tmp_path):
    m, _, _ = fitted
    m.save(tmp_path / "m", {"preset": "paper"})
    with pytest.raises(ValueError, match="provenance lacks"):
        export_onnx(tmp_path / "m", tmp_path / "m.onnx")


@pytest.mark.parametrize("changes", [{"sample_time_s": 0.75}, {"horizon": 8}])
def test_export_refuses_a_model_no_policy_would_run(fitted, tmp_path, capsys, changes):
    """A model trained at another horizon or sample time than its preset's (``gpcnav train --sample-time``)
    was exported (exit 0) and then refused by every command that ran it ("model made for H=6, T=0.75 s
    but preset 'paper' has H=6, T=1.5 s"); now export says so in one line and writes nothing."""
    from gpcnav.cli import main
    m, X, _ = fitted
    m.save(tmp_path / "m", {**PROV, **changes})
    with pytest.raises(ValueError, match="H=6, T=1.5 s"):
        export_onnx(tmp_path / "m", tmp_path / "m.onnx")
    assert main(["export", str(tmp_path / "m"), "--out", str(tmp_path / "m.onnx")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "preset 'paper' has H=6, T=1.5 s" in err[0], err
    assert not (tmp_path / "m.onnx").exists()


@pytest.mark.parametrize("option", [["--sample-time", "0.75"], ["--horizon", "8"]])
def test_train_refuses_settings_no_policy_would_run(tmp_path, capsys, option):
    """``gpcnav train --sample-time``/``--horizon`` away from the preset's trained (on a dataset labelled
    so) a network that export wrote and every command refused; now refused before any work."""
    from gpcnav.cli import main
    code = main(["train", str(tmp_path / "data"), "--out", str(tmp_path / "m"), "--preset", "paper", *option])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "preset 'paper' has H=6, T=1.5 s" in err[0], err
    assert not (tmp_path / "m").exists()


def test_dataset_says_before_labelling_that_train_refuses_labels_at_another_timing(capsys):
    """``gpcnav dataset --horizon 8`` (or ``--sample-time``) labelled for hours a dataset that train
    then refused ("labelled with another planner configuration"), said nowhere before; now a note
    first (the labels are still made: solutions are data of their own)."""
    from casadi_gpc.config import preset
    from gpcnav.commands.dataset import _note_timing
    for changes in ({"horizon": 8}, {"sample_time_s": 0.75}):
        _note_timing(preset("paper").with_overrides(**changes))
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "preset 'paper' has H=6, T=1.5 s: gpcnav train refuses them" in err[0], err
    _note_timing(preset("paper"))
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("option, words", [
    (["--encoder-width", "32"], "--encoder-width: an option of --architecture set"),
    (["--batch-size", "64"], "--batch-size: an option of --optimizer adam"),
    (["--lr", "0.1"], "--lr: an option of --optimizer adam"),
    (["--optimizer", "adam", "--encoder-width", "32"], "--encoder-width: an option of --architecture set"),
    (["--weight-decay=-1"], "--weight-decay must be a finite number, 0 or more, got -1.0"),
    (["--weight-decay", "nan"], "--weight-decay must be a finite number, 0 or more, got nan"),
])
def test_train_refuses_options_the_training_does_not_use(tmp_path, capsys, option, words):
    """--encoder-width without --architecture set, --batch-size and --lr with L-BFGS were taken and
    ignored (the same network as without them); now one line before any work. A negative --weight-decay
    trained (a penalty that rewards large weights) and nan or inf failed after the work as "diverged
    (learning_rate 0.003)", a setting L-BFGS does not use."""
    from gpcnav.cli import main
    code = main(["train", str(tmp_path / "data"), "--out", str(tmp_path / "m"), "--preset", "paper", *option])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and words in err[0], err
    assert not (tmp_path / "m").exists()


@pytest.mark.parametrize("name, words", [("weights.npz", "weights.npz: not a readable weights file ("),
                                         ("validation_features.npy", "validation_features.npy: not a readable array (")])
def test_export_of_a_model_folder_with_a_damaged_file_is_one_line(fitted, tmp_path, capsys, name, words):
    """A model folder whose weights or validation features were cut short (a copy
    interrupted) was a BadZipFile or ValueError traceback in gpcnav export."""
    from gpcnav.cli import main
    m, X, _ = fitted
    m.save(tmp_path / "m", PROV)
    np.save(tmp_path / "m" / "validation_features.npy", X[m.validation_indices_])
    path = tmp_path / "m" / name
    path.write_bytes(path.read_bytes()[:100])
    assert main(["export", str(tmp_path / "m"), "--out", str(tmp_path / "m.onnx")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"gpcnav export: error: {tmp_path / 'm'}: cannot load the trained "
                                               f"model: {words}"), err
    assert not (tmp_path / "m.onnx").exists()


def test_a_save_interrupted_over_an_older_model_leaves_no_model_folder(fitted, tmp_path, capsys, monkeypatch):
    """A `gpcnav train` stopped while saving over an older model folder left the new weights
    under the old model.json: export was a traceback (another shape) or wrote a file whose
    metadata (validation RMSE, dataset, hyper-parameters) were the older model's."""
    import nn_export.training.train as train_module
    from gpcnav.cli import main
    m, X, Y = fitted
    m.save(tmp_path / "m", PROV)
    np.save(tmp_path / "m" / "validation_features.npy", X[m.validation_indices_])
    wider = WheelSpeedMLP(hidden=24, max_epochs=3, random_state=4).fit(X, Y)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(train_module, "save_curve_figure", interrupted)
    with pytest.raises(KeyboardInterrupt):
        wider.save(tmp_path / "m", PROV)
    assert not (tmp_path / "m" / "model.json").exists()
    assert main(["export", str(tmp_path / "m"), "--out", str(tmp_path / "m.onnx")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a trained model folder (no model.json" in err[0], err
    monkeypatch.undo()
    wider.save(tmp_path / "m", PROV, {"validation_features": X[wider.validation_indices_]})
    assert main(["export", str(tmp_path / "m"), "--out", str(tmp_path / "m.onnx")]) == 0
    assert WheelSpeedMLP.load(tmp_path / "m").hidden == 24


def test_deeper_network_roundtrip_and_export_parity(tmp_path):
    """layers=2: saved, loaded and exported with the same parity as the paper's one layer."""
    X, Y = _data()
    m = WheelSpeedMLP(hidden=12, layers=2, max_epochs=20, random_state=1).fit(X, Y)
    p = m.numpy_params()
    assert p["W1"].shape == (12, 17) and p["W1_2"].shape == (12, 12) and p["W2"].shape == (2, 12)
    m.save(tmp_path / "m", PROV)
    m2 = WheelSpeedMLP.load(tmp_path / "m")
    assert m2.layers == 2
    np.testing.assert_array_equal(m2.predict(X), m.predict(X))
    val = X[m.validation_indices_]
    export_onnx(tmp_path / "m", tmp_path / "m.onnx", val)
    sess = ort.InferenceSession(str(tmp_path / "m.onnx"), providers=["CPUExecutionProvider"])
    got = sess.run(None, {INPUT_NAME: val.astype(np.float32)})[0]
    assert np.max(np.abs(got - np.clip(m.predict(val), -0.8, 0.8))) <= 1e-5
    meta = {q.key: q.value for q in onnx.load(tmp_path / "m.onnx").metadata_props}
    assert meta["layers"] == "2" and meta["hidden"] == "12"
    with pytest.raises(ValueError, match="layers"):
        WheelSpeedMLP(layers=0).fit(X, Y)


def test_decision_passes_travel_in_the_metadata(fitted, tmp_path):
    m, X, _ = fitted
    m.save(tmp_path / "m", PROV)
    for passes in (1, 2):
        export_onnx(tmp_path / "m", tmp_path / f"m{passes}.onnx", X[:64], decision_passes=passes)
        meta = {q.key: q.value for q in onnx.load(tmp_path / f"m{passes}.onnx").metadata_props}
        assert meta["decision_passes"] == str(passes)
    with pytest.raises(ValueError, match="decision_passes"):
        export_onnx(tmp_path / "m", tmp_path / "m3.onnx", X[:64], decision_passes=3)
    assert not (tmp_path / "m3.onnx").exists()


def _increment_data(n=1500, seed=2):
    """Labels that are mostly the current wheel speeds (the first two inputs, spread over the
    limits) plus a small turn that depends on three other inputs: the GPC's labels in shape."""
    X, _ = _data(n, seed)
    rng = np.random.default_rng(seed)
    X[:, :2] = rng.uniform(-0.7, 0.7, size=(n, 2))
    Z = (X - np.arange(17)) / np.linspace(0.1, 3.0, 17)
    turn = 0.1 * np.tanh(Z[:, 2] - 0.5 * Z[:, 5] + 0.3 * Z[:, 7])
    return X, X[:, :2] + np.stack([turn, -turn], axis=1)


def test_relative_target_learns_the_increments_and_every_form_answers_wheel_speeds(tmp_path):
    X, Y = _increment_data()
    kw = dict(hidden=8, max_epochs=30, batch_size=128, optimizer="adam", random_state=0)
    rel = WheelSpeedMLP(relative=True, **kw).fit(X, Y)
    ab = WheelSpeedMLP(**kw).fit(X, Y)
    # the same budget fits the increments far better than the whole speeds
    assert rel.validation_mse_ < 0.5 * ab.validation_mse_  # 0.16 measured (0.15-0.35 over seeds 0-2)
    # the network itself answers the increment; predict adds the current speeds back
    with torch.no_grad():
        inc = rel.net_(torch.from_numpy(X)).numpy()
    assert np.abs(inc - (Y - X[:, :2])).mean() < 0.2 * np.abs(X[:, :2]).mean()
    np.testing.assert_allclose(rel.predict(X), inc + X[:, :2], rtol=0, atol=1e-12)
    # saved and loaded as relative; the ONNX graph adds the speeds too (checked by onnxruntime here)
    rel.save(tmp_path / "m", PROV)
    assert json.loads((tmp_path / "m" / "model.json").read_text())["params"]["relative"] is True
    assert "relative" not in ab.get_params()  # a plain model's files stay what they were
    back = WheelSpeedMLP.load(tmp_path / "m")
    np.testing.assert_array_equal(back.predict(X), rel.predict(X))
    export_onnx(tmp_path / "m", tmp_path / "m.onnx", X[:256])
    sess = ort.InferenceSession(str(tmp_path / "m.onnx"), providers=["CPUExecutionProvider"])
    got = sess.run(None, {INPUT_NAME: X.astype(np.float32)})[0]
    assert np.max(np.abs(got - np.clip(rel.predict(X), -0.8, 0.8))) <= 1e-5
    # the addition is one MatMul and one Add in the graph (a traced slice-and-repeat was 25
    # nodes and a fifth of the crowd network's call)
    ab.save(tmp_path / "a", PROV)
    export_onnx(tmp_path / "a", tmp_path / "a.onnx", X[:256])
    ops = [[n.op_type for n in onnx.load(tmp_path / f).graph.node if n.op_type != "Constant"] for f in ("m.onnx", "a.onnx")]
    assert sorted(ops[0]) == sorted(ops[1] + ["MatMul", "Add"])
    # the current speeds must be the first two features
    names = [f"x{i}" for i in range(17)]
    with pytest.raises(ValueError, match="relative needs the current wheel speeds"):
        WheelSpeedMLP(relative=True, max_epochs=1).fit(X, Y, feature_names=names)
    with pytest.raises(ValueError, match="wheel pairs"):
        WheelSpeedMLP(relative=True, output_basis="wheels", max_epochs=1).fit(X, Y[:, :1])


def test_cost_gap_and_its_weights_on_hand_made_costs():
    from nn_export.training.weights import WEIGHT_FLOOR, cost_gap, cost_gap_weights
    nan = float("nan")
    cc = np.array([[2.0, 2.0 * (1 + 1e-9), 2.1, nan],   # the same optimum twice, a runner-up 5 % dearer, a failure
                   [2.0, 2.0, nan, nan],                # one optimum only
                   [1.0, 1.003, 1.015, 1.5],            # a near tie: 0.3 %
                   [-1.0, -0.99, nan, nan]])            # a negative cost: relative to |cost|
    cost = np.array([2.0, 2.0, 1.0, -1.0])
    np.testing.assert_allclose(cost_gap(cc, cost), [0.05, np.inf, 0.003, 0.01], rtol=1e-9)
    np.testing.assert_allclose(cost_gap_weights(cc, cost, 0.03), [1.0, 1.0, WEIGHT_FLOOR, 0.01 / 0.03], rtol=1e-9)
    with pytest.raises(ValueError, match="positive"):
        cost_gap_weights(cc, cost, 0.0)


def test_sample_weights_pull_the_fit_to_the_weighted_mean():
    """Labels that disagree on the same inputs (the two sides of an obstacle): the least-squares
    answer is their mean, the weighted one their weighted mean, exactly."""
    rng = np.random.default_rng(4)
    X, _ = _data(2000, 4)
    side = rng.random(len(X)) < 0.5
    Y = np.where(side, 0.4, -0.4)[:, None] * np.array([1.0, -1.0])     # turn one way or the other
    w = np.where(side, 1.0, 0.25)
    kw = dict(hidden=8, max_epochs=40, batch_size=128, optimizer="adam", random_state=0)
    plain = WheelSpeedMLP(**kw).fit(X, Y).predict(X)[:, 0].mean()
    weighted = WheelSpeedMLP(**kw).fit(X, Y, sample_weight=w).predict(X)[:, 0].mean()
    exact = np.sum(w * Y[:, 0]) / np.sum(w)                             # 0.24 for an even split
    assert abs(plain - Y[:, 0].mean()) < 0.03
    assert abs(weighted - exact) < 0.03 and exact - Y[:, 0].mean() > 0.2
    with pytest.raises(ValueError, match="positive finite"):
        WheelSpeedMLP(**kw).fit(X, Y, sample_weight=np.zeros(len(X)))


@pytest.mark.parametrize("name", ["model.json", "weights.npz"])
def test_export_refuses_an_out_that_is_one_of_the_model_folder_s_own_files(fitted, tmp_path, capsys, name):
    """``gpcnav export M --out M/model.json`` wrote the ONNX bytes over the trained model it had read
    (exit 0), which no command could load again; now one line, and the folder is as it was."""
    from gpcnav.cli import main
    m, X, _ = fitted
    m.save(tmp_path / "m", PROV)
    before = (tmp_path / "m" / name).read_bytes()
    assert main(["export", str(tmp_path / "m"), "--out", str(tmp_path / "m" / name)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"is the trained model's {name} in {tmp_path / 'm'}: it would be overwritten" in err[0]
    assert (tmp_path / "m" / name).read_bytes() == before
    assert main(["export", str(tmp_path / "m"), "--out", str(tmp_path / "m" / "model.onnx")]) == 0  # beside them
