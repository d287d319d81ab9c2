"""The set networks' forward pass compiled (numba), run in place of onnxruntime's call where it
gives the same wheel speeds (numpy, numba and protobuf: onnxruntime's own dependency).

The crowd and walls networks (``set`` and ``set-walls`` layouts, :mod:`nn_export.training.set_net`)
are a graph of 58 small operations. Warm, onnxruntime runs it faster than this loop (21 against
29 us, ``docs/data/deploy/compiled_forward/numba_net.py``); in the closed loop, where the
simulator's and the check's work pushes the network's code and weights out of the processor's
caches between decisions, onnxruntime's call took about 100 us of a 350 us decision, and the
compiled loop, a few kilobytes of code, about half of that: the decision 341-351 -> 290-320 us median (the bench's scene, 10 crossings,
three rounds alternated; docs/nn-deploy.md, "The set networks compiled").

An option (``OnnxPolicy(compiled_set_networks=True)``), not the default: its answers differ from
onnxruntime's in the last bits (under 5e-7 m/s on a recording's decisions), which among people
who see the robot grows into other episodes, and a rule on unseen cases found fewer goals and more
collisions there (docs/data/deploy/compiled_set/rule.md).

The ONNX file stays the network's one definition: its weights are read from the file itself (the
graph's initializers and constants, through a subset of ONNX's protobuf schema written here, so
the ``onnx`` package is not needed), each mapped through the graph's own nodes, and the compiled
pass is used only when it answers like onnxruntime on probe rows made at load (within
:data:`TOLERANCE_MPS`; float32 sums in another order differ in the last bits). A graph of another
shape, or a pass that does not agree, leaves onnxruntime in charge: :func:`compile_set_network`
says why (the policy's ``model_info`` records it)."""
from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["compile_set_network", "CompiledSetNet", "TOLERANCE_MPS", "read_onnx_tensors", "set_network_weights"]

TOLERANCE_MPS = 2e-5
"""The largest difference from onnxruntime's wheel speeds allowed on the probe rows."""
PROBES = 256
"""Probe rows at load: random rows with every slot present, absent, or a mix."""

_MESSAGES = None


def _messages():
    """The five ONNX messages this module reads (field numbers of onnx.proto), built once from a
    descriptor: protobuf skips every field not declared here."""
    global _MESSAGES
    if _MESSAGES is None:
        from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
        F = descriptor_pb2.FieldDescriptorProto
        f = descriptor_pb2.FileDescriptorProto(name="gpcnav_onnx_subset.proto", package="gpcnav_onnx_subset",
                                               syntax="proto2")

        def message(name, *fields):
            m = f.message_type.add(name=name)
            for fname, number, ftype, label, type_name in fields:
                fd = m.field.add(name=fname, number=number, type=ftype, label=label)
                if type_name:
                    fd.type_name = f".gpcnav_onnx_subset.{type_name}"

        rep, opt = F.LABEL_REPEATED, F.LABEL_OPTIONAL
        message("TensorProto", ("dims", 1, F.TYPE_INT64, rep, None), ("data_type", 2, F.TYPE_INT32, opt, None),
                ("float_data", 4, F.TYPE_FLOAT, rep, None), ("int64_data", 7, F.TYPE_INT64, rep, None),
                ("name", 8, F.TYPE_STRING, opt, None), ("raw_data", 9, F.TYPE_BYTES, opt, None))
        message("AttributeProto", ("name", 1, F.TYPE_STRING, opt, None), ("f", 2, F.TYPE_FLOAT, opt, None),
                ("i", 3, F.TYPE_INT64, opt, None), ("t", 5, F.TYPE_MESSAGE, opt, "TensorProto"))
        message("NodeProto", ("input", 1, F.TYPE_STRING, rep, None), ("output", 2, F.TYPE_STRING, rep, None),
                ("op_type", 4, F.TYPE_STRING, opt, None), ("attribute", 5, F.TYPE_MESSAGE, rep, "AttributeProto"))
        message("GraphProto", ("node", 1, F.TYPE_MESSAGE, rep, "NodeProto"),
                ("initializer", 5, F.TYPE_MESSAGE, rep, "TensorProto"))
        message("ModelProto", ("graph", 7, F.TYPE_MESSAGE, opt, "GraphProto"))
        pool = descriptor_pool.DescriptorPool()
        pool.Add(f)
        desc = pool.FindMessageTypeByName("gpcnav_onnx_subset.ModelProto")
        make = getattr(message_factory, "GetMessageClass", None)  # protobuf 4.21+; before, the factory's
        _MESSAGES = make(desc) if make is not None else message_factory.MessageFactory(pool).GetPrototype(desc)
    return _MESSAGES


def _array(t) -> np.ndarray:
    """A TensorProto's values (float32 or int64) in its shape."""
    dtype = {1: np.float32, 7: np.int64}.get(t.data_type)
    if dtype is None:
        raise ValueError(f"tensor {t.name!r} of ONNX type {t.data_type}")
    if t.raw_data:
        a = np.frombuffer(t.raw_data, dtype=np.dtype(dtype).newbyteorder("<")).astype(dtype)
    else:
        a = np.array(t.float_data if dtype is np.float32 else t.int64_data, dtype=dtype)
    return a.reshape(tuple(t.dims))


def read_onnx_tensors(data: bytes) -> tuple[list, dict]:
    """The graph of an ONNX file's bytes: its nodes as ``(op_type, inputs, outputs, attributes)``
    and every named tensor it holds (initializers, and the values of ``Constant`` nodes by their
    output's name) as arrays."""
    from google.protobuf.message import DecodeError
    model = _messages()()
    try:
        model.ParseFromString(data)
    except DecodeError as exc:
        raise ValueError(f"not an ONNX file ({exc})") from None
    g = model.graph
    tensors = {t.name: _array(t) for t in g.initializer}
    nodes = []
    for n in g.node:
        attrs = {a.name: a for a in n.attribute}
        if n.op_type == "Constant" and "value" in attrs:
            tensors[n.output[0]] = _array(attrs["value"].t)
        nodes.append((n.op_type, list(n.input), list(n.output), attrs))
    return nodes, tensors


class CompiledSetNet:
    """The compiled pass of one set network: :meth:`answer` on its float32 input row."""

    def __init__(self, weights: tuple, head_tanh: bool):
        self.weights = weights
        self.head_tanh = head_tanh
        self.out = np.zeros(2, np.float32)

    def answer(self, x: np.ndarray) -> tuple[float, float]:
        """The wheel speeds for the input row ``x`` (float32, the layout's size)."""
        _forward(x, *self.weights, self.head_tanh, self.out)
        return float(self.out[0]), float(self.out[1])


def set_network_weights(nodes, tensors, n_in: int, slots: tuple[int, int, int]) -> tuple[tuple, bool]:
    """The set network's weights, each found through the node that uses it (the graph
    :class:`~nn_export.training.set_net.SetNet` exports, wrapped with its relative output and
    clip), for ``n_in`` inputs whose obstacle slots are ``slots`` (the layout's
    :attr:`~nn_export.runtime.layouts.FeatureLayout.set_slots`), float32 in the compiled pass's
    order, and whether its head is tanh (else relu); a ``ValueError`` naming what does not fit.
    ``gpcnav train --init`` reads a network back through it too
    (:func:`nn_export.training.warm_start.read_set_network`)."""
    ops = [n[0] for n in nodes]

    def operand(op: str, k: int, shape_len: int) -> np.ndarray:
        found = [n for n in nodes if n[0] == op]
        if len(found) <= k:
            raise ValueError(f"no {op} #{k + 1}")
        ins = [tensors[i] for i in found[k][1] if i in tensors]
        if len(ins) != 1 or ins[0].ndim != shape_len:
            raise ValueError(f"{op} #{k + 1} does not take one tensor of rank {shape_len}")
        return np.ascontiguousarray(ins[0], dtype=np.float32)

    if ops[:2] != ["Sub", "Div"] or ops.count("MatMul") != 5 or ops.count("Clip") != 1 or ops[-1] != "Clip":
        raise ValueError("not the set network's graph")
    acts = [ops[i + 1] for i, o in enumerate(ops) if o == "Gemm" and i + 1 < len(ops) and ops[i + 1] in ("Tanh", "Relu")]
    gemms = [n for n in nodes if n[0] == "Gemm"]
    if len(acts) != len(gemms) - 1 or len(set(acts)) != 1 or len(gemms) not in (2, 3):
        raise ValueError("not the set network's head (one or two hidden layers of one activation)")
    for g in gemms:
        a = g[3]
        if a.get("transB") is None or a["transB"].i != 1 or ("transA" in a and a["transA"].i != 0) or \
                any(k in a and abs(a[k].f - 1.0) > 0 for k in ("alpha", "beta")):
            raise ValueError("a Gemm of another form")
    layers = [tuple(np.ascontiguousarray(tensors[name], dtype=np.float32) for name in g[1][1:3]) for g in gemms]
    mean, scale = operand("Sub", 0, 1), operand("Div", 0, 1)
    W_slot, W_wheels, W_enc, W_mix, sel = (operand("MatMul", k, 2) for k in range(5))
    adds = [n for n in nodes if n[0] == "Add" and any(i in tensors for i in n[1])]
    biases = [np.ascontiguousarray([tensors[i] for i in a[1] if i in tensors][0], dtype=np.float32) for a in adds]
    muls = [n for n in nodes if n[0] == "Mul" and any(i in tensors for i in n[1])]
    if len(biases) != 3 or len(muls) != 1:
        raise ValueError("not the set network's biases and output scale")
    b_slot, b_enc, y_mean = biases
    y_scale = np.ascontiguousarray([tensors[i] for i in muls[0][1] if i in tensors][0], dtype=np.float32)
    clip = [n for n in nodes if n[0] == "Clip"][0]
    lo, hi = (float(tensors[i]) for i in clip[1][1:3])
    E = W_enc.shape[0]
    start, n_slots, width = (int(v) for v in slots)
    if W_slot.shape != (width - 1, E) or start + n_slots * width > n_in:
        raise ValueError("the slots do not fit the input")
    if W_wheels.shape != (2, E) or W_enc.shape != (E, E) or len(b_slot) != E or \
            len(b_enc) != E or mean.shape != (n_in,) or scale.shape != (n_in,) or sel.shape != (n_in, 2) or \
            W_mix.shape != (2, 2) or y_mean.shape != (2,) or y_scale.shape != (2,):
        raise ValueError("weights of unexpected shapes")
    if layers[0][0].shape[1] != n_in - n_slots * width + 2 * E or layers[-1][0].shape[0] != 2:
        raise ValueError("the head does not fit the input")
    (W1, b1), *mid, (Wo, bo) = layers
    W2, b2 = mid[0] if mid else (np.zeros((0, 0), np.float32), np.zeros(0, np.float32))
    head = (W1, b1, W2, b2, Wo, bo, len(mid))
    return (mean, scale, start, n_slots, width, W_slot, b_slot, W_wheels, W_enc, b_enc, *head, y_scale, y_mean, W_mix,
            sel, np.float32(lo), np.float32(hi)), acts[0] == "Tanh"


def compile_set_network(data: bytes, n_in: int, slots: tuple[int, int, int],
                        reference) -> tuple[CompiledSetNet | None, str]:
    """The compiled pass of the set network in the ONNX file ``data`` (``n_in`` inputs, its
    obstacle slots ``slots``: ``(first input, slots, inputs per slot)``, the layout's
    ``set_slots``) and a word on it: ``compiled`` when it answers like ``reference`` (onnxruntime's answer to a batch
    of float32 rows, ``(m, n_in) -> (m, 2)``) on :data:`PROBES` probe rows within
    :data:`TOLERANCE_MPS`; else None and why."""
    try:
        nodes, tensors = read_onnx_tensors(data)
        weights, tanh = set_network_weights(nodes, tensors, n_in, slots)
    except (ValueError, KeyError, IndexError, TypeError) as exc:
        return None, f"onnxruntime (the graph is not the set network's: {exc})"
    net = CompiledSetNet(weights, tanh)
    rng = np.random.default_rng(0)
    X = (rng.normal(0.0, 1.0, (PROBES, n_in)) * rng.choice([0.1, 1.0, 4.0], (PROBES, n_in))).astype(np.float32)
    start, n_slots, width = slots
    present = rng.random((PROBES, n_slots)) < rng.random((PROBES, 1))
    X[:, start:start + n_slots * width:width] = present
    X[:, :2] = np.clip(X[:, :2], -0.8, 0.8)
    want = np.asarray(reference(X), dtype=np.float64)
    try:
        got = np.array([net.answer(x) for x in X])
    except (TypeError, ValueError) as exc:  # weights of another type than the compiled signature's
        return None, f"onnxruntime (the compiled pass does not take these weights: {exc})"
    err = float(np.max(np.abs(got - want))) if len(X) else 0.0
    if not np.isfinite(err) or err > TOLERANCE_MPS:
        return None, f"onnxruntime (the compiled pass differs by {err:.3g} m/s on the probe rows)"
    return net, f"compiled (numba; within {err:.2g} m/s of onnxruntime on {PROBES} probe rows)"


_V, _M = "float32[::1]", "float32[:, ::1]"


@njit(f"void({_V}, {_V}, {_V}, int64, int64, int64, {_M}, {_V}, {_M}, {_M}, {_V}, {_M}, {_V}, {_M}, {_V}, {_M}, {_V}, "
      f"int64, {_V}, {_V}, {_M}, {_M}, float32, float32, boolean, {_V})", cache=True)
def _forward(x, mean, scale, start, n_slots, width, W_slot, b_slot, W_wheels, W_enc, b_enc, W1, b1, W2, b2, Wo, bo,
             deeper, y_scale, y_mean, W_mix, sel, lo, hi, tanh, out):  # pragma: no cover - compiled
    """The set network's pass on one float32 row (nn_export.training.set_net.SetNet, then the
    export's relative output and clip), in float32 like the graph."""
    n_in = x.shape[0]
    E = W_enc.shape[0]
    z = np.empty(n_in, np.float32)
    for i in range(n_in):
        z[i] = (x[i] - mean[i]) / scale[i]
    ww = np.zeros(E, np.float32)
    for k in range(E):
        ww[k] = z[0] * W_wheels[0, k] + z[1] * W_wheels[1, k]
    mx = np.full(E, -np.inf, np.float32)
    sm = np.zeros(E, np.float32)
    h = np.empty(E, np.float32)
    for s in range(n_slots):
        base = start + width * s
        pres = z[base]
        for k in range(E):
            acc = np.float32(0.0)
            for i in range(width - 1):
                acc += z[base + 1 + i] * W_slot[i, k]
            v = (b_slot[k] + acc) + ww[k]
            h[k] = v if v > 0 else np.float32(0.0)
        for k in range(E):
            acc = np.float32(0.0)
            for i in range(E):
                acc += h[i] * W_enc[i, k]
            v = b_enc[k] + acc
            v = (v if v > 0 else np.float32(0.0)) * pres
            if v > mx[k]:
                mx[k] = v
            sm[k] += v
    stop = start + width * n_slots
    n_c = start + (n_in - stop) + 2 * E
    c = np.empty(n_c, np.float32)
    for i in range(start):
        c[i] = z[i]
    for i in range(n_in - stop):
        c[start + i] = z[stop + i]
    o = start + n_in - stop
    for k in range(E):
        c[o + k] = mx[k]
        c[o + E + k] = sm[k]
    hid = np.empty(W1.shape[0], np.float32)
    for j in range(W1.shape[0]):
        acc = np.float32(0.0)
        for i in range(n_c):
            acc += W1[j, i] * c[i]
        v = acc + b1[j]
        hid[j] = np.tanh(v) if tanh else (v if v > 0 else np.float32(0.0))
    if deeper:
        h2 = np.empty(W2.shape[0], np.float32)
        for j in range(W2.shape[0]):
            acc = np.float32(0.0)
            for i in range(hid.shape[0]):
                acc += W2[j, i] * hid[i]
            v = acc + b2[j]
            h2[j] = np.tanh(v) if tanh else (v if v > 0 else np.float32(0.0))
        hid = h2
    y = np.empty(2, np.float32)
    for j in range(2):
        acc = np.float32(0.0)
        for i in range(hid.shape[0]):
            acc += Wo[j, i] * hid[i]
        y[j] = (acc + bo[j]) * y_scale[j] + y_mean[j]
    for j in range(2):
        acc = y[0] * W_mix[0, j] + y[1] * W_mix[1, j]
        prev = np.float32(0.0)
        for i in range(n_in):
            prev += x[i] * sel[i, j]
        v = acc + prev
        out[j] = min(max(v, lo), hi)
