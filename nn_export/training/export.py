"""Export a trained :class:`~nn_export.training.train.WheelSpeedMLP` to one ONNX file (torch, onnx).

The graph is the whole deployed map, in float32: standardise the features, the hidden layers,
un-standardise, and clip both wheel speeds to the robot's limit (the largest float32 not above
it: :func:`~nn_export.runtime.model_file.float32_bound`), so the runtime adds nothing of its
own. The standardisation is folded into the first layer's weights and the un-standardisation
(and the output basis) into the last layer's, computed in float64 before the float32 cast: Gemm,
Tanh, ..., Gemm, Clip, half the nodes of the plain form and about 2 us less per call (each node
costs onnxruntime a kernel dispatch). The set network (:mod:`~nn_export.training.set_net`) is
exported as it is, in float32. Input ``features`` (batch, n_features), output
``wheel_speeds_mps`` (batch, 2), right then left, or, for a network trained on plans (``gpcnav
train --target plan``, metadata ``output`` = ``plan``), (batch, 2 H): the right and left wheel
speeds of each of the H steps. The batch axis is dynamic.

Metadata (``metadata_props``, all strings; JSON where structured) say what the model was
trained for; :class:`nn_export.runtime.policy.OnnxPolicy` refuses a file whose metadata do not match
the preset, the robot or the feature layout it is asked to run with. Keys: ``format``,
``feature_layout``, ``feature_layout_version``, ``feature_layout_spec``, ``feature_names``, ``label_names``,
``n_features``, ``preset``, ``horizon``, ``sample_time_s``, ``planner_config``, ``robot``,
``output_clip_mps``, ``output`` (``command`` or ``plan``), ``dataset``, ``validation_rmse_mps``,
``validation_max_abs_error_mps``, ``hidden``, ``layers``, ``decision_passes``, ``activation``, ``trained_with``.
"""
from __future__ import annotations

import copy
import io
import json
import warnings
from pathlib import Path

import numpy as np
import torch

from ..runtime.model_file import float32_bound, timing_mismatch
from .train import WheelSpeedMLP, wheel_selection

__all__ = ["POLICY_FORMAT", "INPUT_NAME", "OUTPUT_NAME", "REQUIRED_METADATA", "export_onnx", "ExportReport"]

POLICY_FORMAT = "gpcnav-onnx-policy/1"
INPUT_NAME = "features"
OUTPUT_NAME = "wheel_speeds_mps"
OPSET = 17
PARITY_TOL = 1e-5
REQUIRED_METADATA = ("format", "feature_layout", "feature_layout_version", "feature_names", "n_features", "preset",
                     "horizon", "sample_time_s", "robot", "output_clip_mps", "dataset", "validation_rmse_mps")


class _Deployed(torch.nn.Module):
    """The trained map (plus the current wheel speeds for a ``relative`` network) followed by
    the wheel-limit clip, in float32."""

    def __init__(self, net, clip_mps: float, selection: torch.Tensor | None = None):
        super().__init__()
        self.net = net
        self.clip_mps = float32_bound(clip_mps)
        self.selection = selection  # float32 wheel_selection of a relative network, else None

    def forward(self, x):
        y = self.net(x)
        if self.selection is not None:
            y = y + x @ self.selection
        return torch.clamp(y, -self.clip_mps, self.clip_mps)


class ExportReport(dict):
    """What :func:`export_onnx` wrote and measured (a dict: path, bytes, parity_max_abs, ...)."""


def export_onnx(model: WheelSpeedMLP | str | Path, out_path, parity_X: np.ndarray | None = None,
                decision_passes: int = 2) -> ExportReport:
    """Write ``model`` (fitted, or a folder saved by ``WheelSpeedMLP.save``) to ``out_path``.

    ``decision_passes`` (metadata ``decision_passes``) is how :class:`~nn_export.OnnxPolicy`
    runs the network by default: 2, the paper's two passes, or 1, one pass with the real
    reference (a network trained on the GPC's own closed-loop states imitates it better that
    way: docs/nn-recipe.md). A caller can still choose either.

    The file is checked with ``onnx.checker`` and, on ``parity_X`` (default: a seeded set of
    points spread over the training normalisation), run with onnxruntime and compared with
    the torch model clipped the same way; a difference above 1e-5 m/s is an error.
    The provenance stored with the model must say the preset, horizon, sample time, robot
    and feature layout (``gpcnav train`` does).
    """
    if not isinstance(model, WheelSpeedMLP):
        model = WheelSpeedMLP.load(model)
    model._check_fitted()
    prov = dict(getattr(model, "provenance_", None) or {})
    missing = [k for k in ("preset", "horizon", "sample_time_s", "robot", "feature_layout", "feature_layout_version")
               if k not in prov]
    if missing:
        raise ValueError(f"the model's provenance lacks {', '.join(missing)} (train it with `gpcnav train`)")
    try:
        mismatch = timing_mismatch(str(prov["preset"]), int(prov["horizon"]), float(prov["sample_time_s"]))
    except ValueError as exc:  # an unknown preset
        mismatch = str(exc)
    if mismatch:  # the loader refuses it: no command would run the file
        raise ValueError(f"{mismatch}: a policy runs a model at its preset's horizon and sample time")
    if decision_passes not in (1, 2):
        raise ValueError(f"decision_passes must be 1 or 2, got {decision_passes!r}")
    if prov.get("output", "command") == "plan" and decision_passes != 1:
        raise ValueError("a plan network runs one pass: export it with --passes 1")
    clip = float(prov["robot"]["max_wheel_speed_mps"])
    meta = _metadata(model, prov, clip, decision_passes)
    data = _onnx_bytes(model, clip, meta)
    if parity_X is None:
        rng = np.random.default_rng(0)
        p = model.numpy_params()
        parity_X = p["x_mean"] + p["x_scale"] * rng.standard_normal((512, model.n_features_in_))
    parity_X = np.asarray(parity_X, dtype=np.float64)
    parity = _parity(model, data, parity_X, clip)

    from casadi_gpc.io import write_bytes
    out_path = Path(out_path)
    write_bytes(out_path, data)
    return ExportReport(path=str(out_path), bytes=len(data), parity_max_abs_mps=parity, parity_samples=len(parity_X),
                        metadata=meta)


def _onnx_bytes(model: WheelSpeedMLP, clip: float, meta: dict) -> bytes:
    """The deployed map (folded, clipped, float32) as a checked ONNX file with ``meta``."""
    import onnx
    selection = (wheel_selection(model.n_features_in_, model.n_outputs_, torch.float32) if model.relative
                 else None)
    deployed = _Deployed(_deployable(model.net_), clip, selection).eval()
    buf = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the TorchScript exporter's deprecation notice
        torch.onnx.export(deployed, (torch.zeros(1, model.n_features_in_, dtype=torch.float32),), buf,
                          dynamo=False, input_names=[INPUT_NAME], output_names=[OUTPUT_NAME],
                          dynamic_axes={INPUT_NAME: {0: "batch"}, OUTPUT_NAME: {0: "batch"}},
                          opset_version=OPSET, do_constant_folding=True)
    proto = onnx.load_from_string(buf.getvalue())
    # the module's name before nn_export.training: kept, so that an export is byte for byte
    # what it was (the file's sha256 keys reproduce's stages and travels in RUN.json)
    proto.producer_name, proto.doc_string = "gpcnav", "GPC-imitating wheel-speed network (nn_export.export)"
    del proto.metadata_props[:]
    for k, v in meta.items():
        proto.metadata_props.add(key=k, value=v)
    onnx.checker.check_model(proto, full_check=True)
    return proto.SerializeToString()


def _metadata(model: WheelSpeedMLP, prov: dict, clip: float, decision_passes: int) -> dict:
    """The metadata of the module docstring, all strings (JSON where structured)."""
    return {
        "format": POLICY_FORMAT,
        "feature_layout": str(prov["feature_layout"]),
        "feature_layout_version": str(prov["feature_layout_version"]),
        "feature_layout_spec": json.dumps(prov.get("feature_layout_spec", {
            "name": prov["feature_layout"], "version": prov["feature_layout_version"], "horizon": prov["horizon"]})),
        "feature_names": json.dumps(model.feature_names_),
        "label_names": json.dumps(model.label_names_),
        "n_features": str(model.n_features_in_),
        "preset": str(prov["preset"]),
        "horizon": str(int(prov["horizon"])),
        "sample_time_s": repr(float(prov["sample_time_s"])),
        "planner_config": json.dumps(prov.get("planner_config", {})),
        "robot": json.dumps(prov["robot"]),
        "output_clip_mps": repr(clip),
        "output": str(prov.get("output", "command")),
        "dataset": json.dumps(prov.get("dataset", {})),
        "validation_rmse_mps": repr(float(np.sqrt(model.validation_mse_))),
        "validation_max_abs_error_mps": repr(float(model.validation_max_abs_error_)),
        "hidden": str(model.hidden),
        "layers": str(getattr(model, "layers", 1)),
        "decision_passes": str(int(decision_passes)),
        "activation": model.activation,
        "trained_with": json.dumps({"params": model.get_params(), "best_epoch": model.best_epoch_,
                                    "stop_reason": model.stop_reason_, **prov.get("training", {})}),
    }


def _parity(model: WheelSpeedMLP, data: bytes, parity_X: np.ndarray, clip: float) -> float:
    """Largest difference (m/s) between onnxruntime on the bytes about to be written and the
    float64 torch model clipped the same way; above :data:`PARITY_TOL` is an error."""
    import onnxruntime as ort
    sess = ort.InferenceSession(data, providers=["CPUExecutionProvider"])
    got = sess.run(None, {INPUT_NAME: parity_X.astype(np.float32)})[0]
    bound = float32_bound(clip)
    want = np.clip(model.predict(parity_X), -bound, bound)
    parity = float(np.max(np.abs(got - want))) if len(parity_X) else 0.0
    if not parity <= PARITY_TOL:
        raise RuntimeError(f"ONNX/torch parity {parity:.3g} m/s exceeds {PARITY_TOL:g}")
    return parity


def _deployable(net) -> torch.nn.Module:
    """The float32 map to export: the perceptron folded (:func:`_folded`); the set network
    (:mod:`~nn_export.training.set_net`) as it is, cast (its standardisation stays a
    subtraction and a division ahead of the slots' reshaping)."""
    from .set_net import SetNet
    if isinstance(net, SetNet):
        return copy.deepcopy(net).float().eval()
    return _folded(net)


def _folded(net) -> torch.nn.Module:
    """The trained map as a float32 stack of Linear and activation layers: (x - mu) / sd
    folded into the first layer (W / sd, b - W mu / sd), u * u_sd + u_mu and the basis matrix
    into the last (mix diag(u_sd) W, mix (u_sd b + u_mu)); the folding in float64."""
    with torch.no_grad():
        lins = [net.hidden, *net.deeper, net.out]
        Ws = [lin.weight.detach().double().clone() for lin in lins]
        bs = [lin.bias.detach().double().clone() for lin in lins]
        mu, sd = net.x_mean.double(), net.x_scale.double()
        bs[0] = bs[0] - Ws[0] @ (mu / sd)
        Ws[0] = Ws[0] / sd[None, :]
        mix, usd, umu = net.y_mix.double(), net.y_scale.double(), net.y_mean.double()
        Ws[-1] = mix @ (usd[:, None] * Ws[-1])
        bs[-1] = mix @ (usd * bs[-1] + umu)
        layers = []
        for i, (W, b) in enumerate(zip(Ws, bs)):
            lin = torch.nn.Linear(W.shape[1], W.shape[0])
            lin.weight.copy_(W.float())
            lin.bias.copy_(b.float())
            layers.append(lin)
            if i < len(Ws) - 1:
                layers.append(type(net.act)())
        return torch.nn.Sequential(*layers).eval()
