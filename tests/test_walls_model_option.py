"""``--walls-model`` and ``--crowd-model`` (simulate, evaluate, compare): the deployed network with a walls or
crowd network of the user's (one trained further by ``gpcnav train --init``) in place of the shipped one;
recorded in RUN.json, part of a resumed run's key, and refused in one line (exit 2) for another controller or
a file that is not such a network."""
from __future__ import annotations

import hashlib
import json
import subprocess
import sys

import pytest

from casadi_gpc.config import preset

pytest.importorskip("onnx")


def _scene(name: str, duration_s: float, rest: str) -> str:
    """A scenario file: the robot at the origin on an 8 m path along +x at 0.4 m/s, and ``rest``."""
    return (f'name = "{name}"\nduration_s = {duration_s}\n[robot]\nposition = [0.0, 0.0]\nheading_deg = 0.0\n'
            '[reference]\nposition = [0.0, 0.0]\nheading_deg = 0.0\nspeed_mps = 0.4\n[[reference.segments]]\n'
            f'line_m = 8.0\n{rest}')


ALONG_A_WALL = _scene("along-a-wall-on-the-left", 30.0, "[[walls]]\npoints = [[-10.0, 1.25], [20.0, 1.25]]\n")
CROWD = _scene("three-walkers-aside", 6.0, "".join(
    f"[[moving_obstacles]]\nposition = [{x}, 4.0]\nheading_deg = 0.0\nspeed_mps = 0.3\nradius_m = 0.3\n"
    for x in (1.0, 3.0, 5.0)))


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


def test_the_crowd_network_given_answers_among_several_movers_and_is_recorded(files):
    d, _, _, crowd = files
    scene = d / "crowd.toml"
    scene.write_text(CROWD)
    gpcnav("simulate", scene, "--controller", "nn", "--crowd-model", crowd, "--out", d / "crowd.json")
    doc = json.loads((d / "crowd.json").read_text())
    assert doc["events"]["crowd_network"] == doc["steps"] > 0
    assert doc["model"]["crowd_model"]["sha256"] == hashlib.sha256(crowd.read_bytes()).hexdigest()


def test_a_run_with_another_walls_network_is_another_run():
    from gpcnav.commands.episode_store import run_key
    from gpcnav.controllers import ControllerSpec
    from nn_export.runtime.policy import shipped_crowd_model_path, shipped_walls_model_path
    cfg = preset("improved")
    walls, crowd = shipped_walls_model_path("improved"), shipped_crowd_model_path("improved")
    keys = {run_key(ControllerSpec("nn", walls_model=w, crowd_model=c), cfg, {})
            for w, c in ((None, None), (walls, None), (crowd, None), (None, crowd))}
    assert len(keys) == 4


def test_walls_model_refused_in_one_line(files):
    d, scene, _, crowd = files
    for argv, words in (
            (("simulate", scene, "--controller", "gpc", "--walls-model", crowd), "options of --controller nn"),
            (("simulate", scene, "--controller", "orca", "--crowd-model", crowd), "options of --controller nn"),
            (("simulate", scene, "--controller", "nn", "--crowd-model", d / "none.onnx"), "no such model file"),
            (("simulate", scene, "--controller", "nn", "--walls-model", crowd), "must read walls"),
            (("simulate", scene, "--controller", "nn", "--walls-model", d / "none.onnx"), "no such model file"),
            (("compare", scene, "--controllers", "gpc,stand", "--walls-model", crowd),
             "--walls-model: for the controller nn")):
        err = gpcnav(*argv, "--out", d / "x.json", rc=2).stderr
        assert len(err.strip().splitlines()) == 1 and words in err, err
    assert not (d / "x.json").exists()
    walls_copy = d / "walls-copy.onnx"
    walls_copy.write_bytes(files[2].read_bytes())
    err = gpcnav("simulate", scene, "--controller", "nn", "--walls-model", walls_copy, "--out", walls_copy, rc=2).stderr
    assert len(err.strip().splitlines()) == 1 and "model file" in err, err  # the run would have written over it
    assert walls_copy.read_bytes() == files[2].read_bytes()
