"""The network's rows of ``gpcnav bench``: the full :class:`OnnxPolicy` decision beside the
GPC's, and the network call with onnxruntime, numpy and torch.

The network rows time the call as the deployed policy makes it, inside its decisions: the
recorded observations are replayed through an :class:`OnnxPolicy` whose network call
(``_run``: the features already packed into the bound input row, the two outputs read
after it) is wrapped in a timer, and the numpy and torch rows swap their forward pass in
for onnxruntime's in the same replay. The replays are repeated in rounds, the backends'
order rotating, so that a burst of load hits them alike.

Timed apart, the same call measures what the policy never pays. The row used to time it
interleaved, input by input, with the numpy and torch forward passes: each onnxruntime call
then came right after a torch one, whose code and data had pushed onnxruntime's out of the
caches. Measured on the 2-core machine under load (medians, /tmp scripts of the nnspeed
branch, onnxruntime 1.31.1 and 1.32.0 alternating in separate processes, the same numbers
within 0.3 us): back to back 5.1-5.8 us, right after a numpy forward pass 15 us, right
after a torch one 21 us (the old row: 22 us), inside the policy's one-pass decisions
7.6-7.9 us. The onnxruntime version changed nothing; the 15 us against 6 us of issue 12 is
the old row's order of calls and the load of the moment, and 6 us was the warm call. The
back-to-back figure is kept in the onnxruntime row (``back_to_back_time_s``) for comparison.

The forward passes evaluate the exported ONNX graph itself, so the three rows compute the
same function: :func:`graph_forward` runs its few node types (Sub, Div, Gemm, MatMul, Tanh,
Mul, Add, Clip, ...) with numpy or with torch, and each row reports its largest difference
from onnxruntime on the network inputs of the replay. Needs onnx (and torch for the torch
row); the deployed policy does not import this module.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from casadi_gpc.safety import Shield

from ..runtime.policy import OnnxPolicy

__all__ = ["policy_entries", "ObservationRecorder", "network_inputs", "graph_forward", "forward_rows",
           "unmeasured_reason", "network_speedups", "network_summary"]


class ObservationRecorder:
    """An :class:`OnnxPolicy` that keeps the observations it is given (one list append
    inside the timed decision), for the network rows, which replay them."""

    def __init__(self, policy: OnnxPolicy):
        self.policy = policy
        self.sample_time_s = policy.sample_time_s
        self.observations: list = []

    def reset(self) -> None:
        self.policy.reset()
        self.observations = []

    def decide(self, obs):
        self.observations.append(obs)
        return self.policy.decide(obs)


def network_inputs(policy: OnnxPolicy, observations) -> np.ndarray:
    """The last network input of each of ``policy``'s decisions on ``observations`` (reset
    first, open loop), shape (decisions, n_features), float32."""
    policy.reset()
    rows = []
    for obs in observations:
        policy.decide(obs)
        rows.append(policy._x[0].copy())
    return np.array(rows, dtype=np.float32).reshape(len(rows), policy.layout.size)


def policy_entries(config, robot, model=None) -> tuple[list, ObservationRecorder]:
    """``(name, make_policy)`` pairs for :func:`gpcnav.benchmarks.solvers.policy_rows`: the full
    decision as deployed (the model's own number of passes, metadata ``decision_passes``),
    bare and behind the check layer (:class:`casadi_gpc.safety.Shield`, manoeuvres only), and
    with one and with two passes."""
    recorder = ObservationRecorder(OnnxPolicy(model, preset=config.name, robot=robot))
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


def _timed(call, times: list):
    """``call`` (no arguments) timed into ``times``."""
    clock = time.perf_counter

    def run():
        t0 = clock()
        call()
        times.append(clock() - t0)

    return run


def _torch_call(proto, x_in: np.ndarray, y_out: np.ndarray, X: np.ndarray, ref: np.ndarray):
    """``(call, largest difference from onnxruntime on X)`` of the graph's torch forward pass
    on the bound buffers, or None without torch."""
    try:
        import torch
    except ImportError:
        return None
    torch.set_num_threads(1)
    t_f = graph_forward(proto, "torch")

    def torch_call():
        with torch.no_grad():
            y_out[...] = t_f(x_in).numpy()

    with torch.no_grad():
        diff = float(np.max(np.abs(t_f(X).numpy() - ref)))
    return torch_call, diff


ROUNDS = 5
"""Replays of the recorded observations per network row."""


def forward_rows(model_path, observations, rounds: int = ROUNDS, robot=None) -> list[dict]:
    """Rows ``onnxruntime``, ``nn-numpy`` and ``nn-torch``: every network call of an
    :class:`OnnxPolicy` (the model's own number of passes, for ``robot``: the model's own
    without) deciding on ``observations``, timed inside its decisions (module docstring),
    ``rounds`` replays each; with each row's largest output difference from onnxruntime on
    the network inputs of a replay, and for onnxruntime the same call timed back to back
    (``back_to_back_time_s``), for comparison.

    No rows (``[]``) where the replay never called the model's own network: every decision
    went to a side network (the walls network beside walls, the crowd network), whose calls
    these rows do not time (:func:`unmeasured_reason` says so). They were rows of 0.000 ms
    over no call before 2026-11-30 (``gpcnav bench`` of any corridor file)."""
    import onnx
    from scenarios.metrics import time_stats
    model_path = Path(model_path)
    proto = onnx.load(model_path)
    policy = OnnxPolicy(model_path) if robot is None else OnnxPolicy(model_path, robot=robot)
    X = network_inputs(policy, observations)
    ref = policy.network(X)
    x_in, y_out = policy._x, policy._y  # the bound buffers the policy packs and reads
    ort_run = policy._run
    calls, diffs, skipped = {"onnxruntime": ort_run}, {"onnxruntime": 0.0}, {}
    try:
        np_f = graph_forward(proto, "numpy")
    except ValueError as exc:  # a graph with other nodes (the set network's): said, not timed
        np_f = None
        skipped = {"nn-numpy": str(exc), "nn-torch": str(exc)}
    if np_f is not None:
        def np_call():
            y_out[...] = np_f(x_in)

        calls["nn-numpy"] = np_call
        diffs["nn-numpy"] = float(np.max(np.abs(np_f(X) - ref)))
    torch_row = _torch_call(proto, x_in, y_out, X, ref) if np_f is not None else None
    if torch_row is not None:
        calls["nn-torch"], diffs["nn-torch"] = torch_row
    names = list(calls)
    times = {k: [] for k in names}
    for k in range(rounds):
        for j in range(len(names)):
            name = names[(j + k) % len(names)]
            policy._run = _timed(calls[name], times[name])
            policy.reset()
            for obs in observations:
                policy.decide(obs)
    policy._run = ort_run
    if not times["onnxruntime"]:
        return []
    warm = []
    for x in X:
        x_in[0] = x
        for _ in range(3):
            t0 = time.perf_counter()
            ort_run()
            warm.append(time.perf_counter() - t0)
    passes = "two passes" if policy.two_pass else "one pass"
    rows = [{"name": k, "kind": "policy", "problems": len(times[k]), "time_s": time_stats(times[k]),
             "note": f"the network call inside the deployed policy's decisions ({passes}, {len(observations)} "
                     f"recorded observations x {rounds} rounds)",
             "max_abs_diff_to_onnxruntime_mps": diffs[k]} for k in names]
    rows[0]["back_to_back_time_s"] = time_stats(warm)
    if skipped:
        rows[0]["skipped_rows"] = skipped
    return rows


def unmeasured_reason(model_path, observations, robot=None) -> str:
    """Why :func:`forward_rows` made no rows on ``observations``: the side networks that
    took the decisions, counted over one replay."""
    policy = OnnxPolicy(model_path) if robot is None else OnnxPolicy(model_path, robot=robot)
    policy.reset()
    for obs in observations:
        policy.decide(obs)
    counters = policy.counters
    side = [f"the {role} network {counters[role + '_network']}" for role in ("walls", "crowd")
            if counters.get(role + "_network")]
    return (f"network call rows (onnxruntime, nn-numpy, nn-torch) not measured: none of the {len(observations)} "
            f"decisions called the model's own network ({', '.join(side) or 'a side network'} of them)")


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


def network_summary(rows: list[dict]) -> str | None:
    """One line of the network's medians in microseconds (None without an onnxruntime row)."""
    med = {r["name"]: r["time_s"]["median"] * 1e6 for r in rows if r.get("kind") == "policy"}
    ort_row = next((r for r in rows if r["name"] == "onnxruntime"), None)
    if ort_row is None:
        return None
    b2b = ort_row.get("back_to_back_time_s", {}).get("median")
    parts = [f"network: the onnxruntime call inside the policy's decisions {med['onnxruntime']:.1f} us"
             + (f" (back to back {b2b * 1e6:.1f} us)" if b2b else "")]
    for name, label in (("onnxpolicy[one-pass]", "one-pass decision"), ("onnxpolicy[two-pass]", "two passes"),
                        ("onnxpolicy[+safety-brake]", "behind the check layer")):
        if name in med:
            parts.append(f"{label} {med[name]:.1f} us")
    line = "; ".join(parts) + " (medians)"
    if ort_row.get("skipped_rows"):
        skipped = ort_row["skipped_rows"]
        line += f"; rows not measured: {', '.join(skipped)} ({next(iter(skipped.values()))})"
    return line
