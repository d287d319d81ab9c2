"""``--walls-model`` (simulate, evaluate, compare): the deployed network with a walls network of the user's
(one trained further by ``gpcnav train --init``) in place of the shipped one; recorded in RUN.json, part
of a resumed run's key, and refused in one line (exit 2) for another controller or a file that is not a
walls network."""
from __future__ import annotations

import hashlib
import json
import subprocess
import sys

import pytest

from casadi_gpc.config import preset

pytest.importorskip("onnx")

ALONG_A_WALL = """name = "along-a-wall-on-the-left"
duration_s = 30.0
[robot]
position = [0.0, 0.0]
heading_deg = 0.0
[reference]
position = [0.0, 0.0]
heading_deg = 0.0
speed_mps = 0.4
[[reference.segments]]
line_m = 8.0
[[walls]]
points = [[-10.0, 1.25], [20.0, 1.25]]
"""


def gpcnav(*argv, rc=0):
    proc = subprocess.run([sys.executable, "-m", "gpcnav", *map(str, argv)], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == rc, proc.stderr[-2000:]
    return proc


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    from synthetic_models import tracker_model
    d = tmp_path_factory.mktemp("walls_model")
    scene = d / "wall.toml"
    scene.write_text(ALONG_A_WALL)
    # an obstacle-blind tracker of the reference, in the walls network's layout
    walls = tracker_model(d / "tracker-walls.onnx", "improved", layout_name="set-walls", decision_passes="1")
    crowd = tracker_model(d / "tracker-set.onnx", "improved", layout_name="set", decision_passes="1")
    return d, scene, walls, crowd


def test_the_walls_network_given_answers_near_walls_and_is_recorded(files):
    d, scene, walls, _ = files
    gpcnav("simulate", scene, "--controller", "nn", "--walls-model", walls, "--out", d / "run.json")
    doc = json.loads((d / "run.json").read_text())
    # the tracker drives along the wall to its goal (the shipped walls network stops short there:
    # tests/test_walls_network_reach.py), and answered every decision
    assert doc["outcome"] == "reached_goal"
    assert doc["events"]["walls_network"] == doc["steps"]
    assert doc["model"]["walls_model"]["sha256"] == hashlib.sha256(walls.read_bytes()).hexdigest()


def test_a_run_with_another_walls_network_is_another_run():
    from gpcnav.commands.episode_store import run_key
    from gpcnav.controllers import ControllerSpec
    from nn_export.runtime.policy import shipped_crowd_model_path, shipped_walls_model_path
    cfg = preset("improved")
    keys = {run_key(ControllerSpec("nn", walls_model=w), cfg, {}) for w in (
        None, shipped_walls_model_path("improved"), shipped_crowd_model_path("improved"))}
    assert len(keys) == 3


def test_walls_model_refused_in_one_line(files):
    d, scene, _, crowd = files
    for argv, words in (
            (("simulate", scene, "--controller", "gpc", "--walls-model", crowd), "options of --controller nn"),
            (("simulate", scene, "--controller", "nn", "--walls-model", crowd), "must read walls"),
            (("simulate", scene, "--controller", "nn", "--walls-model", d / "none.onnx"), "no such model file"),
            (("compare", scene, "--controllers", "gpc,stand", "--walls-model", crowd),
             "--walls-model: for the controller nn")):
        err = gpcnav(*argv, "--out", d / "x.json", rc=2).stderr
        assert len(err.strip().splitlines()) == 1 and words in err, err
    assert not (d / "x.json").exists()
