"""Model files that must be refused when they are loaded, with one clear line, never a
crash at the first decision: truncated, corrupted, empty, not ONNX, or made for another
preset, robot, feature layout or input size."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from casadi_gpc.robot import RobotParams

from conftest import PAPER_DIR
from synthetic_models import tracker_model

SCENARIO = PAPER_DIR / "fig7_1_head_on.toml"


def good(tmp_path, preset_name="improved", **kw):
    return tracker_model(tmp_path / f"good_{preset_name}.onnx", preset_name, **kw)


def _bad_files(tmp_path):
    """name -> (path, what the one-line message must mention)."""
    src = good(tmp_path)
    data = src.read_bytes()
    out = {}

    def write(name, blob):
        p = tmp_path / f"{name}.onnx"
        p.write_bytes(blob)
        return p

    out["truncated"] = (write("truncated", data[: len(data) // 2]), "not a readable ONNX model")
    rng = np.random.default_rng(0)
    garbage = bytearray(data)
    garbage[8:72] = rng.integers(0, 256, 64, dtype=np.uint8).tobytes()
    out["corrupted"] = (write("corrupted", bytes(garbage)), "")
    out["empty"] = (write("empty", b""), "not a readable ONNX model")
    out["text"] = (write("text", b"this is not a model\n"), "not a readable ONNX model")
    out["nan_weights"] = (tracker_model(tmp_path / "nan.onnx", "improved", weight_fill=np.nan), "non-finite")
    out["other_preset"] = (good(tmp_path, "paper"), "preset")
    out["other_robot"] = (tracker_model(tmp_path / "robot.onnx", "improved", robot=RobotParams(wheel_base_m=0.6)),
                          "robot")
    out["input_size"] = (tracker_model(tmp_path / "inputs.onnx", "improved", n_inputs=20), "input")
    from nn_export.runtime.layouts import layout_for
    spec = {**layout_for("paper", 12).to_dict(), "version": 99}  # features of a future version of the code
    out["layout_version"] = (tracker_model(tmp_path / "version.onnx", "improved", feature_layout_version="99",
                                           feature_layout_spec=json.dumps(spec)), "version")
    out["not_ours"] = (tracker_model(tmp_path / "format.onnx", "improved", format="someone-else/1"),
                       "not a gpcnav policy model")
    out["missing_file"] = (tmp_path / "nowhere.onnx", "no such model file")
    return out


KINDS = ["truncated", "corrupted", "empty", "text", "nan_weights", "other_preset", "other_robot", "input_size",
         "layout_version", "not_ours", "missing_file"]


@pytest.fixture(scope="module")
def bad_files(tmp_path_factory):
    return _bad_files(tmp_path_factory.mktemp("bad_models"))


def test_the_good_file_loads_and_decides(tmp_path):
    from nn_export import OnnxPolicy
    pol = OnnxPolicy(good(tmp_path), preset="improved")
    assert pol.model_info["n_features"] == pol.layout.size
    assert "safety_filter" not in pol.model_info  # the bare network: the check layer wraps it (Shield)


@pytest.mark.parametrize("kind", KINDS)
def test_bad_model_file_is_refused_at_load_with_one_line(bad_files, kind):
    from nn_export import OnnxPolicy
    path, mention = bad_files[kind]
    err = FileNotFoundError if kind == "missing_file" else ValueError
    with pytest.raises(err) as info:
        OnnxPolicy(path, preset="improved")
    msg = str(info.value)
    assert "\n" not in msg and len(msg) < 400, msg
    assert str(path) in msg and mention in msg, msg


@pytest.mark.parametrize("kind", ["truncated", "corrupted", "nan_weights", "other_preset", "input_size",
                                  "missing_file"])
def test_simulate_with_a_bad_model_exits_2_with_one_line(bad_files, kind, tmp_path):
    path, mention = bad_files[kind]
    out = tmp_path / "RUN.json"
    r = subprocess.run([sys.executable, "-m", "gpcnav", "simulate", str(SCENARIO), "--controller", "nn",
                        "--model", str(path), "--out", str(out)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 2, r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gpcnav simulate: error: "), r.stderr
    assert str(path) in lines[0] and mention in lines[0]
    assert "Traceback" not in r.stderr and r.stdout == ""
    assert not out.exists()


def test_evaluate_with_a_bad_model_exits_2_before_any_episode(bad_files, tmp_path):
    path, _ = bad_files["truncated"]
    out = tmp_path / "EVAL.json"
    r = subprocess.run([sys.executable, "-m", "gpcnav", "evaluate", "--suite", "random", "--count", "3",
                        "--controller", "nn", "--model", str(path), "--workers", "1", "--out", str(out)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert "Traceback" not in r.stderr and not out.exists()
