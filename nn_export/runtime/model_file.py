"""A policy model file: loaded into an onnxruntime session, checked against what it is asked
to run with, and bound to preallocated buffers (numpy + onnxruntime only).

A model file is checked when it is loaded, never at the first decision: it must be a
readable ONNX graph written by :mod:`nn_export.training.export` (format key), with one float
input of the size its feature layout says and one output of (batch, 2) (a command) or, for a
plan network (metadata ``output`` = ``plan``), (batch, 2 H), a feature layout name and
version this code computes, a preset, horizon and sample time equal to the ones it is asked
to run with, and the robot it was trained for or a smaller one (:func:`serves_robot`).
Anything else is a one-line ``ValueError`` (``FileNotFoundError`` for a missing file).
"""
from __future__ import annotations

import json
import math
import struct
from functools import partial
from pathlib import Path

import numpy as np
import onnxruntime as ort

from casadi_gpc.config import PlannerConfig, preset as preset_config
from casadi_gpc.robot import RobotParams

from .layouts import FeatureLayout, layout_from_dict

__all__ = ["POLICY_FORMAT", "INPUT_NAME", "OUTPUT_NAME", "read_model_metadata", "float32_bound", "serves_robot",
           "timing_mismatch"]

POLICY_FORMAT = "gpcnav-onnx-policy/1"  # written by nn_export.training.export (kept equal by a test)
INPUT_NAME, OUTPUT_NAME = "features", "wheel_speeds_mps"
_REQUIRED = ("format", "feature_layout", "feature_layout_version", "feature_names", "n_features", "preset", "horizon",
             "sample_time_s", "robot", "output_clip_mps", "dataset", "validation_rmse_mps")


def serves_robot(model_robot: dict, robot: RobotParams) -> bool:
    """Whether a network trained for ``model_robot`` (its metadata's ``robot``) drives ``robot``:
    the same robot, or one that differs only in being smaller. The network's inputs never
    read the robot's radius (it learnt the trained robot's clearances), so a smaller robot
    driven by it keeps the larger robot's distances, and the check layer judges its commands
    with the robot's own radius (docs/model.md, "Robots of other sizes"). Its wheels, their
    limits and their base must be the trained ones: the network's outputs are those wheels'
    speeds."""
    return _wheels(model_robot) == _wheels(robot.to_dict()) and _drives_disc(model_robot, robot)


def _wheels(robot: dict) -> dict:
    return {k: v for k, v in robot.items() if k != "radius_m"}


def _drives_disc(model_robot: dict, robot: RobotParams) -> bool:
    """Whether ``robot``'s disc is no larger than the trained robot's (the radius rule of
    :func:`serves_robot`)."""
    radius = model_robot.get("radius_m")
    return isinstance(radius, (int, float)) and 0 < robot.radius_m <= radius


def timing_mismatch(preset_name: str, horizon: int, sample_time_s: float) -> str | None:
    """Why a network made for ``horizon`` and ``sample_time_s`` under the preset ``preset_name``
    cannot run (a policy runs a model at its preset's horizon and sample time), or None. Read by
    the loader, and by ``gpcnav train`` and ``export``, which refuse such a network before it is
    made (a model trained with ``--sample-time`` was exported, then refused by every command)."""
    cfg = preset_config(preset_name)
    if cfg.horizon != horizon or not math.isclose(cfg.sample_time_s, sample_time_s):
        return (f"model made for H={horizon}, T={sample_time_s} s but preset {preset_name!r} has H={cfg.horizon}, "
                f"T={cfg.sample_time_s} s")
    return None


def float32_bound(limit_mps: float) -> float:
    """The largest float32 not above ``limit_mps`` (positive): the graph's clip bound. The
    float32 nearest the limit may lie above it (float32(0.8) is 0.800000011920929), and a
    saturated output read in float64 would then exceed the wheel limit by 1e-8, which the
    robot holds, and the check (``candidate_limited``) and the simulator
    (``clipped_commands``) count as clipped: 34 of 38 clipped commands in 10 crowd episodes
    were that rounding alone (docs/nn-training.md)."""
    b = np.float32(limit_mps)
    if float(b) > limit_mps:
        b = np.nextafter(b, np.float32(0.0))
    return float(b)


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return text[0][:200] if text else type(exc).__name__


def read_model_metadata(session: ort.InferenceSession, path: Path | None = None) -> dict:
    """The model's metadata; unreadable ones (corrupt bytes in an otherwise loadable file) a
    ``ValueError`` naming ``path``."""
    try:
        return dict(session.get_modelmeta().custom_metadata_map)
    except (UnicodeDecodeError, RuntimeError, ValueError) as exc:
        raise ValueError(f"{path or 'the model'}: unreadable model metadata ({_one_line(exc)})") from None


def _load_session(path: Path) -> tuple[ort.InferenceSession, bytes]:
    if not path.is_file():
        raise FileNotFoundError(f"{path}: {'a folder, not a model file' if path.is_dir() else 'no such model file'}")
    data = path.read_bytes()
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 1  # a 17-35-2 net gains nothing from threads, and loses to their wake-up
    opts.inter_op_num_threads = 1
    opts.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    opts.log_severity_level = 3
    # no memory arena: the few small intermediate rows come from malloc, which is cheaper per
    # call than the arena's bookkeeping (the bare call 10.2 -> 9.9 us on the 2-core machine,
    # interleaved; the same outputs bit for bit, tested)
    opts.enable_cpu_mem_arena = False
    try:
        return ort.InferenceSession(data, opts, providers=["CPUExecutionProvider"]), data
    except Exception as exc:  # onnxruntime raises its own classes for truncated or corrupt files
        raise ValueError(f"{path}: not a readable ONNX model ({_one_line(exc)})") from None


def _bound_run(session: ort.InferenceSession, binding) -> "partial":
    """A call without arguments that runs ``session`` on the bound buffers.

    The policy calls the network H + 1 times per decision, so the per-call overhead
    counts: onnxruntime's Python ``run_with_iobinding`` wraps the C++ method with a
    graph-capture check (about 0.4 us), and the C++ method given no RunOptions makes one
    per call (about 0.8 us; 1.31, measured). So the C++ method of the session is called
    directly, with one RunOptions made here, when this onnxruntime has it (it has since
    1.x: ``InferenceSession._sess``, ``IOBinding._iobinding``); else the public method."""
    sess, ib = getattr(session, "_sess", None), getattr(binding, "_iobinding", None)
    if callable(getattr(sess, "run_with_iobinding", None)) and ib is not None:
        return partial(sess.run_with_iobinding, ib, ort.RunOptions())
    return partial(session.run_with_iobinding, binding)


def _bind(session: ort.InferenceSession, size: int, path: Path, outputs: int = 2) -> tuple:
    """``(x, y, write, binding, run)``: one preallocated float32 input row ``x`` (1, size) and
    output row ``y`` (1, ``outputs``: 2, or 2 H for a plan network) bound to ``session`` once,
    ``write(*values)`` packing a list of feature values into ``x`` in one call (float64 ->
    float32 rounding as numpy's), and
    ``run()`` (:func:`_bound_run`). The first call is made now (it allocates), and a file whose
    network gives non-finite wheel speeds is refused (``ValueError``)."""
    x = np.zeros((1, size), dtype=np.float32)
    y = np.zeros((1, outputs), dtype=np.float32)
    write = partial(struct.Struct(f"={size}f").pack_into, memoryview(x).cast("B"), 0)
    binding = session.io_binding()
    binding.bind_ortvalue_input(INPUT_NAME, ort.OrtValue.ortvalue_from_numpy(x))
    binding.bind_ortvalue_output(OUTPUT_NAME, ort.OrtValue.ortvalue_from_numpy(y))
    run = _bound_run(session, binding)
    run()
    if not np.all(np.isfinite(y)):  # corrupt numbers in an otherwise valid file
        raise ValueError(f"{path}: the network gives non-finite wheel speeds (corrupt weights?)")
    return x, y, write, binding, run


def _validate(path: Path, session: ort.InferenceSession, meta: dict, preset: str | None,
              robot: RobotParams) -> tuple[FeatureLayout, PlannerConfig, int]:
    """The checks of the module docstring; returns the layout, the preset's config and the
    steps each output row holds (1: a command; H: a plan, metadata ``output`` = ``plan``)."""
    if meta.get("format") != POLICY_FORMAT:
        raise ValueError(f"{path}: not a gpcnav policy model (metadata format {meta.get('format')!r}, "
                         f"expected {POLICY_FORMAT!r})")
    missing = [k for k in _REQUIRED if k not in meta]
    if missing:
        raise ValueError(f"{path}: model metadata lacks {', '.join(missing)}")
    try:
        spec = json.loads(meta["feature_layout_spec"]) if "feature_layout_spec" in meta else {
            "name": meta["feature_layout"], "version": meta["feature_layout_version"], "horizon": meta["horizon"]}
        spec["feature_names"] = json.loads(meta["feature_names"])
        n_features, horizon = int(meta["n_features"]), int(meta["horizon"])
        sample_time_s = float(meta["sample_time_s"])
        model_robot = json.loads(meta["robot"])
        clip = float(meta["output_clip_mps"])
    except (ValueError, TypeError, KeyError) as exc:
        raise ValueError(f"{path}: malformed model metadata ({_one_line(exc)})") from None
    try:
        layout = layout_from_dict(spec)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    if layout.size != n_features:
        raise ValueError(f"{path}: layout {layout.name!r} has {layout.size} inputs but the metadata say {n_features}")
    inputs, outputs = session.get_inputs(), session.get_outputs()
    if len(inputs) != 1 or inputs[0].name != INPUT_NAME or inputs[0].type != "tensor(float)":
        raise ValueError(f"{path}: the graph must have one float input {INPUT_NAME!r}")
    if len(inputs[0].shape) != 2 or inputs[0].shape[1] != n_features:
        raise ValueError(f"{path}: the graph's input has shape {inputs[0].shape}, the layout needs "
                         f"[batch, {n_features}]")
    kind = meta.get("output", "command")
    if kind not in ("command", "plan"):
        raise ValueError(f"{path}: metadata output is {kind!r}, expected 'command' or 'plan'")
    steps = 1 if kind == "command" else horizon
    if len(outputs) != 1 or len(outputs[0].shape) != 2 or outputs[0].shape[1] != 2 * steps:
        raise ValueError(f"{path}: the graph must have one output of shape [batch, {2 * steps}] ({kind})")
    name = meta["preset"]
    if preset is not None and name != preset:
        raise ValueError(f"{path}: model trained for preset {name!r}, refusing to run it under preset {preset!r}")
    try:
        cfg = preset_config(name)
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None
    mismatch = timing_mismatch(name, horizon, sample_time_s)
    if mismatch or layout.horizon != horizon:
        raise ValueError(f"{path}: {mismatch or timing_mismatch(name, layout.horizon, sample_time_s)}")
    if not serves_robot(model_robot, robot):
        mine, drives_disc = robot.to_dict(), _drives_disc(model_robot, robot)
        # a smaller disc it drives: only what refuses the robot is named (the wheels, or a larger disc)
        diff = sorted(k for k in set(model_robot) | set(mine)
                      if model_robot.get(k) != mine.get(k) and not (k == "radius_m" and drives_disc))
        larger = diff == ["radius_m"]
        raise ValueError(f"{path}: model trained for another robot ({', '.join(diff)} differ: "
                         f"{ {k: model_robot.get(k) for k in diff} } vs { {k: mine.get(k) for k in diff} }"
                         f"{'; it drives robots up to its own radius' if larger else ''})")
    if not math.isclose(clip, robot.max_wheel_speed_mps):
        raise ValueError(f"{path}: output clip {clip} m/s differs from the wheel limit {robot.max_wheel_speed_mps}")
    return layout, cfg, steps
