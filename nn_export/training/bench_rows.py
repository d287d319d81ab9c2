"""The network's rows of ``gpcnav bench``: the full :class:`OnnxPolicy` decision beside the
GPC's, and the bare network call with numpy, torch and onnxruntime on the same situations.

The forward passes evaluate the exported ONNX graph itself, so the three rows compute the
same function: :func:`graph_forward` runs its few node types (Sub, Div, Gemm, MatMul, Tanh,
Mul, Add, Clip, ...) with numpy or with torch, and each row reports its largest difference
from onnxruntime. Needs onnx (and torch for the torch row); the deployed policy does not
import this module.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from casadi_gpc.safety import Shield

from ..runtime.policy import OnnxPolicy

__all__ = ["policy_entries", "FeatureRecorder", "graph_forward", "forward_rows", "network_speedups"]


class FeatureRecorder:
    """An :class:`OnnxPolicy` that keeps a copy of the first feature vector of every decision
    (the situation as observed), for the forward-pass rows."""

    def __init__(self, policy: OnnxPolicy):
        self.policy = policy
        self.sample_time_s = policy.sample_time_s
        self.features: list[np.ndarray] = []

    def reset(self) -> None:
        self.policy.reset()
        self.features = []

    def decide(self, obs):
        dec = self.policy.decide(obs)
        self.features.append(self.policy._x[0].copy())  # the last network input of this decision
        return dec


def policy_entries(config, robot, model=None) -> tuple[list, FeatureRecorder]:
    """``(name, make_policy)`` pairs for :func:`casadi_gpc.bench.policy_rows`: the full
    decision as deployed (the model's own number of passes, metadata ``decision_passes``),
    bare and behind the check layer (:class:`casadi_gpc.safety.Shield`, manoeuvres only), and
    with one and with two passes."""
    recorder = FeatureRecorder(OnnxPolicy(model, preset=config.name, robot=robot))
    entries = [
        ("onnxpolicy", lambda: recorder),
        ("onnxpolicy[one-pass]", lambda: OnnxPolicy(model, preset=config.name, robot=robot, two_pass=False)),
        ("onnxpolicy[two-pass]", lambda: OnnxPolicy(model, preset=config.name, robot=robot, two_pass=True)),
        ("onnxpolicy[+safety-brake]", lambda: Shield(OnnxPolicy(model, preset=config.name, robot=robot), robot)),
    ]
    return entries, recorder


def _attr(node, name, default):
    for a in node.attribute:
        if a.name == name:
            import onnx
            return onnx.helper.get_attribute_value(a)
    return default


def graph_forward(model_proto, xp: str = "numpy"):
    """A function ``f(X) -> Y`` evaluating the ONNX graph with numpy or torch (float32)."""
    from onnx import numpy_helper
    g = model_proto.graph
    consts = {i.name: numpy_helper.to_array(i).astype(np.float32) for i in g.initializer}
    for n in g.node:
        if n.op_type == "Constant":
            consts[n.output[0]] = numpy_helper.to_array(_attr(n, "value", None)).astype(np.float32)
    nodes = [n for n in g.node if n.op_type != "Constant"]
    if xp == "torch":
        import torch
        consts = {k: torch.from_numpy(np.ascontiguousarray(v)) for k, v in consts.items()}
        lib = {"Tanh": torch.tanh, "Relu": torch.relu, "MatMul": torch.matmul,
               "Clip": lambda x, lo, hi: torch.clamp(x, lo, hi),
               "T": lambda a: a.T, "asarray": lambda x: torch.from_numpy(np.asarray(x, np.float32))}
    else:
        lib = {"Tanh": np.tanh, "Relu": lambda x: np.maximum(x, 0), "MatMul": np.matmul,
               "Clip": lambda x, lo, hi: np.clip(x, lo, hi), "T": lambda a: a.T,
               "asarray": lambda x: np.asarray(x, np.float32)}
    for n in nodes:
        if n.op_type not in ("Sub", "Div", "Mul", "Add", "Gemm", "MatMul", "Tanh", "Relu", "Clip", "Identity"):
            raise ValueError(f"graph_forward: unsupported node {n.op_type}")

    def f(X):
        env = dict(consts)
        env[g.input[0].name] = lib["asarray"](X)
        for n in nodes:
            a = [env[i] if i else None for i in n.input]
            op = n.op_type
            if op == "Sub":
                r = a[0] - a[1]
            elif op == "Div":
                r = a[0] / a[1]
            elif op == "Mul":
                r = a[0] * a[1]
            elif op == "Add":
                r = a[0] + a[1]
            elif op == "MatMul":
                r = lib["MatMul"](a[0], a[1])
            elif op == "Gemm":
                A = lib["T"](a[0]) if _attr(n, "transA", 0) else a[0]
                B = lib["T"](a[1]) if _attr(n, "transB", 0) else a[1]
                r = _attr(n, "alpha", 1.0) * lib["MatMul"](A, B)
                if len(a) > 2 and a[2] is not None:
                    r = r + _attr(n, "beta", 1.0) * a[2]
            elif op in ("Tanh", "Relu"):
                r = lib[op](a[0])
            elif op == "Clip":
                r = lib["Clip"](a[0], a[1], a[2])
            else:
                r = a[0]
            env[n.output[0]] = r
        return env[g.output[0].name]

    return f


def _time_rows(features: np.ndarray, calls: dict) -> list[dict]:
    """Time each ``calls[name](x)`` on every single-row input, interleaved row by row."""
    from casadi_gpc.metrics import time_stats
    times = {k: [] for k in calls}
    for x in features:
        for name, fn in calls.items():
            t0 = time.perf_counter()
            fn(x)
            times[name].append(time.perf_counter() - t0)
    return [{"name": k, "kind": "policy", "problems": len(v), "time_s": time_stats(v),
             "note": "network forward pass only, one situation per call, preallocated input"}
            for k, v in times.items()]


def forward_rows(model_path, features: np.ndarray) -> list[dict]:
    """Rows ``nn-numpy``, ``nn-torch`` and ``onnxruntime``: one network call per recorded
    situation, with each row's largest output difference from onnxruntime."""
    import onnx
    model_path = Path(model_path)
    proto = onnx.load(model_path)
    policy = OnnxPolicy(model_path)
    X = np.ascontiguousarray(features, dtype=np.float32)
    ref = policy.network(X)
    x_buf = policy._x
    run = policy._run

    def ort_call(x):
        x_buf[0] = x
        run()
        return policy._y

    calls = {"onnxruntime": ort_call}
    np_f = graph_forward(proto, "numpy")
    calls["nn-numpy"] = lambda x: np_f(x[None, :])
    diffs = {"onnxruntime": 0.0, "nn-numpy": float(np.max(np.abs(np_f(X) - ref)))}
    try:
        import torch
        torch.set_num_threads(1)
        t_f = graph_forward(proto, "torch")

        def torch_call(x):
            with torch.no_grad():
                return t_f(x[None, :])

        with torch.no_grad():
            diffs["nn-torch"] = float(np.max(np.abs(t_f(X).numpy() - ref)))
        calls["nn-torch"] = torch_call
    except ImportError:
        pass
    rows = _time_rows(X, calls)
    for r in rows:
        r["max_abs_diff_to_onnxruntime_mps"] = diffs[r["name"]]
    return rows


def network_speedups(rows: list[dict], chosen: str, reference: str) -> dict:
    """GPC full decision over the network's, and the solvers over the bare network call."""
    med = {r["name"]: r["time_s"]["median"] for r in rows}
    out = {}
    for gpc in (f"gpc[{reference}]", f"gpc[{chosen}]"):
        if gpc in med and med.get("onnxpolicy"):
            out[f"{gpc}/onnxpolicy"] = med[gpc] / med["onnxpolicy"]
    for name in (reference, chosen):
        if name in med and med.get("onnxruntime"):
            out[f"{name}/onnxruntime"] = med[name] / med["onnxruntime"]
    return out
