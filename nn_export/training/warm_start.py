"""A set network read back from its exported ONNX file, to be trained further (``gpcnav train
--init``): a shipped network taught situations its data lacked, without its recipe's hours of
labelling again (docs/nn-training.md, "Training a shipped network further").

The file stays the network's one definition: its weights are found through the graph's own nodes
by the reader the compiled pass uses (:func:`nn_export.runtime.compiled_set.set_network_weights`),
and put under :class:`~nn_export.training.set_net.SetNet`'s names, with the standardisation and the
output basis the network was trained with (its weights are tied to them). The exported weights are
float32: the network read back answers as the file does up to float32 rounding (tested)."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from nn_export.runtime.compiled_set import read_onnx_tensors, set_network_weights
from nn_export.runtime.layouts import layout_from_dict

__all__ = ["read_set_network", "start_from"]


def _metadata(path: Path) -> dict:
    import onnx
    try:
        model = onnx.load(str(path), load_external_data=False)
    except Exception as exc:  # onnx raises protobuf's and its own classes for a file that is not a model
        raise ValueError(f"{path}: not a readable ONNX model ({str(exc).strip().splitlines()[0][:200]})") from None
    return {p.key: p.value for p in model.metadata_props}


def read_set_network(path) -> dict:
    """The set network in the exported ONNX file ``path``: ``state`` (SetNet's state dict, float64
    arrays), its shape (``hidden``, ``layers``, ``encoder_width``, ``activation``; it is always a
    ``--relative`` network: the reader takes the graph ``gpcnav export`` writes for those),
    ``feature_names``, ``preset``, ``layout`` (its name) and ``metadata``; a ``ValueError`` naming what
    is not such a network."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such model file")
    meta = _metadata(path)
    try:
        layout = layout_from_dict(json.loads(meta["feature_layout_spec"]))
    except (KeyError, ValueError, TypeError) as exc:
        raise ValueError(f"{path}: not a gpcnav policy model (no readable feature layout: {exc})") from None
    if not layout.is_set:
        raise ValueError(f"{path}: a network of the {layout.name!r} layout; --init reads set networks only")
    try:
        nodes, tensors = read_onnx_tensors(path.read_bytes())
        w, tanh = set_network_weights(nodes, tensors, layout.size, layout.set_slots)
    except (ValueError, KeyError, IndexError, TypeError) as exc:
        raise ValueError(f"{path}: not the set network's graph that gpcnav export writes ({exc})") from None
    (mean, scale, _start, _n, _width, W_slot, b_slot, W_wheels, W_enc, b_enc, W1, b1, W2, b2, Wo, bo, deeper,
     y_scale, y_mean, W_mix, sel, _lo, _hi) = w
    wheels = np.zeros_like(sel)
    wheels[0, 0] = wheels[1, 1] = 1.0
    if not np.array_equal(sel, wheels):
        raise ValueError(f"{path}: its output does not add the current wheel speeds (not a --relative network)")
    state = {"enc_slot.weight": W_slot.T, "enc_slot.bias": b_slot, "enc_wheels.weight": W_wheels.T,
             "enc_out.weight": W_enc.T, "enc_out.bias": b_enc, "hidden.weight": W1, "hidden.bias": b1,
             **({"deeper.0.weight": W2, "deeper.0.bias": b2} if deeper else {}), "out.weight": Wo, "out.bias": bo,
             "x_mean": mean, "x_scale": scale, "y_mean": y_mean, "y_scale": y_scale, "y_mix": W_mix.T}
    return {"state": {k: np.array(v, dtype=np.float64) for k, v in state.items()},
            "hidden": int(W1.shape[0]), "layers": 1 + int(deeper), "encoder_width": int(W_enc.shape[0]),
            "activation": "tanh" if tanh else "relu", "feature_names": layout.feature_names,
            "preset": meta.get("preset"), "layout": layout.name, "metadata": meta}


def start_from(net, init_state: dict, mix: np.ndarray) -> tuple:
    """``init_state`` (a state of ``net``'s architecture, :func:`read_set_network`'s) loaded into the
    fresh torch network ``net``, whose output basis is ``mix``: its standardisation
    ``(x_mean, x_scale, y_mean, y_scale)``; a ``ValueError`` naming what does not fit."""
    import torch
    try:
        net.load_state_dict({k: torch.from_numpy(np.asarray(v, dtype=np.float64)) for k, v in init_state.items()})
    except RuntimeError as exc:  # torch lists every missing, unexpected and mis-shaped weight
        raise ValueError("the initial weights do not fit this network: " + " ".join(str(exc).split())[:300]) from None
    if not np.allclose(np.asarray(init_state["y_mix"]), mix, rtol=0.0, atol=1e-6):
        raise ValueError("the initial network was trained in another output basis")
    return tuple(np.array(init_state[k], dtype=np.float64) for k in ("x_mean", "x_scale", "y_mean", "y_scale"))
