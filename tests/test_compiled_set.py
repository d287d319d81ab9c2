"""The set networks' compiled pass (nn_export.runtime.compiled_set): the same wheel speeds as
onnxruntime on the shipped crowd and walls networks, its weights read from the file as the onnx
package reads them, and onnxruntime left in charge of a graph it does not know or a pass that
does not agree."""
from __future__ import annotations

import numpy as np
import onnxruntime as ort
import pytest

from casadi_gpc.robot import RobotParams
from nn_export import OnnxPolicy
from nn_export.runtime.compiled_set import TOLERANCE_MPS, compile_set_network, read_onnx_tensors
from nn_export.runtime.model_file import INPUT_NAME
from nn_export.runtime.policy import shipped_crowd_model_path, shipped_model_path, shipped_walls_model_path

SET_NETS = [p for p in (shipped_crowd_model_path("improved"), shipped_walls_model_path("improved")) if p.is_file()]
SLOTS = (2, 18, 9)
"""The shipped set networks' obstacle slots (their layouts' ``set_slots``; checked below)."""


def _reference(path):
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    n_in = session.get_inputs()[0].shape[1]
    return n_in, (lambda X: session.run(None, {INPUT_NAME: X})[0])


def _rows(n_in: int, n: int, seed: int) -> np.ndarray:
    """Rows like a decision's: wheel speeds within the limits, every 9-wide slot present or not."""
    rng = np.random.default_rng(seed)
    X = (rng.normal(0.0, 1.0, (n, n_in)) * rng.choice([0.05, 0.5, 3.0], (n, n_in))).astype(np.float32)
    X[:, :2] = rng.uniform(-0.8, 0.8, (n, 2))
    start, n_slots, width = SLOTS
    X[:, start:start + n_slots * width:width] = rng.random((n, n_slots)) < rng.random((n, 1))
    return X


@pytest.mark.parametrize("path", SET_NETS, ids=lambda p: p.name)
def test_the_compiled_pass_gives_onnxruntime_s_wheel_speeds(path):
    n_in, reference = _reference(path)
    net, executor = compile_set_network(path.read_bytes(), n_in, SLOTS, reference)
    assert net is not None and executor.startswith("compiled"), executor
    X = _rows(n_in, 2000, seed=7)  # not the probe rows
    want = reference(X).astype(float)
    got = np.array([net.answer(x) for x in X])
    assert np.abs(got - want).max() <= TOLERANCE_MPS
    assert np.abs(got).max() <= 0.8 and np.abs(want - got).max() < 1e-4 * np.abs(want).max()


@pytest.mark.parametrize("path", SET_NETS + [shipped_model_path("improved")], ids=lambda p: p.name)
def test_the_weights_are_read_as_the_onnx_package_reads_them(path):
    onnx = pytest.importorskip("onnx")
    from onnx import numpy_helper
    model = onnx.load(str(path))
    nodes, tensors = read_onnx_tensors(path.read_bytes())
    assert [n[0] for n in nodes] == [n.op_type for n in model.graph.node]
    want = {t.name: numpy_helper.to_array(t) for t in model.graph.initializer}
    want.update({n.output[0]: numpy_helper.to_array(n.attribute[0].t) for n in model.graph.node
                 if n.op_type == "Constant"})
    assert set(tensors) == set(want)
    for name, a in want.items():
        assert tensors[name].dtype == a.dtype and np.array_equal(tensors[name], a), name


def test_a_graph_it_does_not_know_or_a_pass_that_does_not_agree_stays_with_onnxruntime():
    main = shipped_model_path("improved")  # a plain perceptron, not a set network
    n_in, reference = _reference(main)
    net, executor = compile_set_network(main.read_bytes(), n_in, SLOTS, reference)
    assert net is None and executor.startswith("onnxruntime (the graph is not the set network's")
    if not SET_NETS:
        return
    n_in, reference = _reference(SET_NETS[0])
    net, executor = compile_set_network(SET_NETS[0].read_bytes(), n_in, SLOTS, lambda X: reference(X) + 1e-3)
    assert net is None and "differs by 0.001" in executor
    net, executor = compile_set_network(b"not a model", n_in, SLOTS, reference)
    assert net is None and executor.startswith("onnxruntime")
    net, executor = compile_set_network(SET_NETS[0].read_bytes(), n_in, (2, 17, 9), reference)  # other slots
    assert net is None and executor.startswith("onnxruntime")


@pytest.mark.skipif(not SET_NETS, reason="no shipped set network")
def test_the_policy_says_which_ran_and_decides_alike_either_way():
    """onnxruntime by default (the rule of docs/data/deploy/compiled_set/rule.md did not adopt
    the compiled pass); the option answers within the tolerance."""
    compiled, plain = OnnxPolicy(preset="improved", compiled_set_networks=True), OnnxPolicy(preset="improved")
    assert compiled._crowd.layout.set_slots == compiled._walls.layout.set_slots == SLOTS
    assert compiled.model_info["crowd_model"]["executor"].startswith("compiled")
    assert plain.model_info["crowd_model"]["executor"] == "onnxruntime"
    X = _rows(compiled._crowd.layout.size, 200, seed=3)
    for x in X:
        a, b = compiled._crowd.answer(x.astype(float).tolist()), plain._crowd.answer(x.astype(float).tolist())
        assert max(abs(a[0] - b[0]), abs(a[1] - b[1])) <= TOLERANCE_MPS
    assert RobotParams() == compiled.robot
