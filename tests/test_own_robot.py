"""A network for the user's own robot: ``gpcnav dataset --robot SCENARIO.toml`` labels for the robot
of that file (its wheel base, radius and limits), and the network trained and exported from the
dataset drives that robot and refuses the default one. The command had no robot option: a user
whose robot is not the contract's could not make a network that drives it."""
from __future__ import annotations

import json

import pytest

from casadi_gpc.robot import RobotParams
from conftest import straight_line_toml
from nn_export.training.sampler_settings import SamplerSettings

SMALL = RobotParams(wheel_base_m=0.5, radius_m=0.2, max_wheel_speed_mps=0.4, max_wheel_accel_mps2=0.6)
SMALL_ROBOT = ("radius_m = 0.2\nmax_wheel_speed_mps = 0.4\nmax_wheel_accel_mps2 = 0.6\n")


class _Result:
    def __init__(self, returncode: int, stderr: str):
        self.returncode, self.stderr = returncode, stderr


@pytest.fixture
def _cli(capsys, monkeypatch):
    """``gpcnav`` in this process (its start-up is most of a small run's time), from folder ``cwd``."""
    from gpcnav.cli import main

    def run(cwd, *args):
        monkeypatch.chdir(cwd)
        capsys.readouterr()
        code = main([str(a) for a in args])
        return _Result(code, capsys.readouterr().err)
    return run


@pytest.fixture
def small_file(tmp_path):
    path = tmp_path / "small.toml"
    text = straight_line_toml("small_line", duration_s=40.0, line_m=4.0).replace("speed_mps = 0.4", "speed_mps = 0.2")
    path.write_text(text.replace("[robot]\n", "[robot]\n" + SMALL_ROBOT, 1), encoding="utf-8")
    return path


def test_the_sampler_draws_references_as_fractions_of_the_robot_s_wheel_limit():
    base = SamplerSettings()
    assert base.for_robot(RobotParams()) is base                     # the default robot's dataset is unchanged
    half = base.for_robot(SMALL)                                     # 0.4 m/s: half the default's wheel limit
    assert half.ref_speed_mps == (0.075, 0.3) and half.rollout_speed_mps == (0.05, 0.3)
    assert half.obstacle_speed_mps == base.obstacle_speed_mps       # people walk as fast for any robot


def test_a_dataset_for_a_file_s_robot_trains_a_network_that_drives_that_robot_only(tmp_path, small_file, _cli):
    from nn_export import OnnxPolicy
    r = _cli(tmp_path, "dataset", "--out", "d", "--samples", "300", "--robot", small_file, "--preset", "paper",
             "--workers", "1")
    assert r.returncode == 0, r.stderr
    man = json.loads((tmp_path / "d" / "manifest.json").read_text())
    assert man["robot"] == SMALL.to_dict()
    assert man["parts"]["offpolicy"]["request"]["sampler"]["ref_speed_mps"] == [0.075, 0.3]
    # the labels keep to the robot's own wheel limit
    import numpy as np
    labels = np.concatenate([np.load(tmp_path / "d" / s)["labels"] for s in man["shards"]])
    assert np.abs(labels).max() <= SMALL.max_wheel_speed_mps + 1e-9
    for argv in (("train", "d", "--out", "m", "--preset", "paper", "--epochs", "20"), ("export", "m", "--out", "m.onnx")):
        r = _cli(tmp_path, *argv)
        assert r.returncode == 0, r.stderr
    OnnxPolicy(tmp_path / "m.onnx", preset="paper", robot=SMALL)
    with pytest.raises(ValueError, match="model trained for another robot"):
        OnnxPolicy(tmp_path / "m.onnx", preset="paper", robot=RobotParams())
    r = _cli(tmp_path, "simulate", small_file, "--controller", "nn", "--preset", "paper", "--model", "m.onnx")
    assert r.returncode == 0, r.stderr
    # an on-policy round labels for the dataset's robot: the suites drive the default robot, files of its own do
    r = _cli(tmp_path, "dataset", "--out", "d", "--dagger", "gpc", "--preset", "paper", "--episodes", "1")
    assert r.returncode == 2 and "labelled for another robot than the suites drive" in r.stderr
    r = _cli(tmp_path, "dataset", "--out", "d", "--dagger", "gpc", "--preset", "paper", "--dagger-files", small_file,
             "--workers", "1")
    assert r.returncode == 0, r.stderr
    man = json.loads((tmp_path / "d" / "manifest.json").read_text())
    assert "gpc1" in man["parts"] and man["robot"] == SMALL.to_dict() and man["samples"] > 300


def test_robot_options_that_cannot_apply_are_refused_in_one_line(tmp_path, small_file, _cli):
    bad = tmp_path / "bad.toml"
    bad.write_text(small_file.read_text().replace("radius_m = 0.2", "radius_m = -0.2"), encoding="utf-8")
    r = _cli(tmp_path, "dataset", "--out", "d", "--samples", "10", "--robot", bad, "--workers", "1")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "robot.radius_m" in r.stderr
    assert not (tmp_path / "d").exists()
    r = _cli(tmp_path, "dataset", "--out", "d", "--dagger", "gpc", "--robot", small_file)
    assert r.returncode == 2 and r.stderr.strip() == ("gpcnav dataset: error: --robot applies to a new dataset: a "
                                                      "--dagger round labels for its dataset's robot")
