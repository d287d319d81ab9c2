"""Small hand-made policy models for the safety and model-file tests (onnx, no torch).

:func:`tracker_model` writes an ONNX file in the exact format ``gpcnav export`` writes
(metadata included) whose "network" is a fixed linear map of the features followed by the
wheel-limit clip: it follows the reference (first desired point and heading) and ignores
every obstacle. A network that never learned to avoid anything is what the safety filter
is for, so this is the model the safety tests drive into obstacles.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from casadi_gpc.config import PlannerConfig, preset
from casadi_gpc.robot import RobotParams
from nn_export.runtime.layouts import layout_for
from nn_export.runtime.model_file import float32_bound

POLICY_FORMAT = "gpcnav-onnx-policy/1"


def tracker_weights(layout, config: PlannerConfig, robot: RobotParams) -> tuple[np.ndarray, np.ndarray]:
    """(n_features, 2) weights and (2,) bias of the obstacle-blind reference follower:
    forward speed = the reference speed plus the along-track error over one interval, turn
    from the cross-track error and the heading error."""
    names = layout.feature_names
    T = config.sample_time_s
    W = np.zeros((layout.size, 2))
    k_along, k_cross, k_head = 0.5 / T, 0.6 / T, 0.25 * robot.wheel_base_m / T
    W[names.index("ref_speed_mps")] = [1.0, 1.0]
    W[names.index("ref_x_m")] = [k_along, k_along]
    W[names.index("ref_y_m")] = [k_cross, -k_cross]
    W[names.index("ref_heading_rad")] = [k_head, -k_head]
    # the first desired point is one interval of reference travel ahead, so the along-track
    # term alone would ask for the reference speed twice: take that interval back out
    b = np.zeros(2)
    return W, b


def model_metadata(config: PlannerConfig, robot: RobotParams, layout, **overrides) -> dict:
    meta = {
        "format": POLICY_FORMAT,
        "feature_layout": layout.name,
        "feature_layout_version": str(layout.version),
        "feature_layout_spec": json.dumps(layout.to_dict()),
        "feature_names": json.dumps(list(layout.feature_names)),
        "label_names": json.dumps(["v_right_mps", "v_left_mps"]),
        "n_features": str(layout.size),
        "preset": config.name,
        "horizon": str(config.horizon),
        "sample_time_s": repr(config.sample_time_s),
        "planner_config": json.dumps(config.to_dict()),
        "robot": json.dumps(robot.to_dict()),
        "output_clip_mps": repr(robot.max_wheel_speed_mps),
        "dataset": json.dumps({"name": "synthetic tracker (tests/synthetic_models.py)"}),
        "validation_rmse_mps": "0.0",
        "validation_max_abs_error_mps": "0.0",
        "hidden": "0",
        "activation": "none",
        "trained_with": "{}",
    }
    meta.update(overrides)
    return meta


def tracker_model(path, preset_name: str = "improved", robot: RobotParams | None = None, layout_name: str = "paper",
                  n_inputs: int | None = None, weight_fill: float | None = None, extra_weights: dict | None = None,
                  **meta_overrides) -> Path:
    """Write the obstacle-blind tracker as ``path``; ``n_inputs`` makes the graph's input
    another size than the layout's (a mismatched file), ``weight_fill`` overwrites every
    weight (NaN: a file whose numbers are corrupt), ``extra_weights`` (feature name ->
    (right, left) weight) makes it read more inputs, ``meta_overrides`` change metadata."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    robot = robot or RobotParams()
    config = preset(preset_name)
    layout = layout_for(layout_name, config.horizon)
    W, b = tracker_weights(layout, config, robot)
    for name, w in (extra_weights or {}).items():
        W[layout.feature_names.index(name)] = w
    n = layout.size if n_inputs is None else int(n_inputs)
    if n != layout.size:
        W = np.resize(W, (n, 2))
    if weight_fill is not None:
        W = np.full_like(W, weight_fill)
    clip = float32_bound(robot.max_wheel_speed_mps)  # as gpcnav export clips
    graph = helper.make_graph(
        [helper.make_node("MatMul", ["features", "W"], ["xw"]),
         helper.make_node("Add", ["xw", "b"], ["raw"]),
         helper.make_node("Clip", ["raw", "lo", "hi"], ["wheel_speeds_mps"])],
        "tracker",
        [helper.make_tensor_value_info("features", TensorProto.FLOAT, ["batch", n])],
        [helper.make_tensor_value_info("wheel_speeds_mps", TensorProto.FLOAT, ["batch", 2])],
        [numpy_helper.from_array(W.astype(np.float32), "W"), numpy_helper.from_array(b.astype(np.float32), "b"),
         numpy_helper.from_array(np.array(-clip, np.float32), "lo"),
         numpy_helper.from_array(np.array(clip, np.float32), "hi")],
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)], producer_name="gpcnav-tests")
    model.ir_version = 8
    for k, v in model_metadata(config, robot, layout, **meta_overrides).items():
        model.metadata_props.add(key=k, value=v)
    onnx.checker.check_model(model, full_check=True)
    path = Path(path)
    path.write_bytes(model.SerializeToString())
    return path



def with_clip_bound(src: Path, bound: float, dst: Path) -> Path:
    """``src`` (a ``gpcnav export`` file) written to ``dst`` with its one Clip node's bounds
    set to ``-bound, bound`` (float32), nothing else changed."""
    import onnx
    from onnx import numpy_helper
    model = onnx.load(str(src))
    consts = {n.output[0]: n for n in model.graph.node if n.op_type == "Constant"}
    clips = [n for n in model.graph.node if n.op_type == "Clip"]
    if len(clips) != 1:
        raise ValueError(f"{src}: {len(clips)} Clip nodes, expected one")
    for name, sign in zip(clips[0].input[1:3], (-1.0, 1.0)):
        t = consts[name].attribute[0].t
        t.CopyFrom(numpy_helper.from_array(np.array(sign * bound, np.float32), t.name))
    onnx.checker.check_model(model, full_check=True)
    dst.write_bytes(model.SerializeToString())
    return dst
