"""The controller registry: every name makes what it says, a user's own class runs from a
module outside the project (simulate and evaluate, in worker processes too), and the three
ways a ``MODULE:CLASS`` can be wrong exit 2 with one line."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import pytest

from casadi_gpc.config import preset
from casadi_gpc.robot import RobotParams
from conftest import REPO, check_run_document, straight_line_toml
from gpcnav.controllers import BUILTIN, ControllerSpec, check, make
from gpcnav.errors import UsageError

CONFIG = preset("improved")

# a straight 4 m path at 0.4 m/s and nothing in the way (10 s to the end)
EMPTY = straight_line_toml("empty_line", duration_s=20.0)

# the README's example, as a user would write it (outside the project)
USER_MODULE = textwrap.dedent('''
    from casadi_gpc import ControlDecision

    class MyPolicy:
        """Drive straight at the reference speed."""
        sample_time_s = 0.5

        def reset(self):
            self.decisions = 0

        def decide(self, observation):
            self.decisions += 1
            v = observation.reference.speed_mps
            return ControlDecision(v_right_mps=v, v_left_mps=v)

    class NoDecide:
        sample_time_s = 0.5

        def reset(self):
            pass

    class NeedsArguments:
        def __init__(self, gain):
            self.gain = gain

    class ReturnsTuple(MyPolicy):
        def decide(self, observation):
            return (0.1, 0.1)

    class RaisesOnALongLine(MyPolicy):
        """Raises at 2 s on a reference longer than 4 m (the files' ``line_m``)."""
        def decide(self, observation):
            if observation.t_s >= 2.0 and observation.reference.end_pose[0] > 4.5:
                raise RuntimeError("sensor\\nglitch")
            return super().decide(observation)

    class RaisesInReset(MyPolicy):
        def reset(self):
            raise KeyError("calibration")

    class SampleTimeRaises(MyPolicy):
        @property
        def sample_time_s(self):
            raise RuntimeError("no clock yet")
''')


def _cli(cwd, *args, timeout=300):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", "gpcnav", *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, cwd=cwd, env=env)


@pytest.fixture
def outside(tmp_path):
    """A folder outside the project with the user's module and a scenario file in it."""
    (tmp_path / "mymod.py").write_text(USER_MODULE, encoding="utf-8")
    (tmp_path / "empty.toml").write_text(EMPTY, encoding="utf-8")
    (tmp_path / "empty2.toml").write_text(EMPTY, encoding="utf-8")
    assert REPO not in tmp_path.parents
    return tmp_path


def test_every_builtin_name_makes_its_controller():
    robot = RobotParams()
    made = {name: make(ControllerSpec(name), CONFIG, robot) for name in BUILTIN}
    assert type(made["gpc"]).__name__ == "Shield" and type(made["gpc"].policy).__name__ == "GPCController"
    assert type(made["nn"]).__name__ == "Shield" and type(made["nn"].policy).__name__ == "OnnxPolicy"
    for name, behaviour in (("orca", "ORCA"), ("hrvo", "HRVO"), ("social_force", "SocialForce")):
        peer = made[name]
        assert type(peer).__name__ == "NavgroundPeer" and peer.settings.behaviour == behaviour
        assert peer.sample_time_s == 0.1 and peer.settings.safety_margin_m == 0.15
    assert type(made["mppi"]).__name__ == "MPPIPeer" and made["mppi"].sample_time_s == CONFIG.sample_time_s
    # the shield modes: a peer goes behind the same Shield, gpc can run bare
    assert type(make(ControllerSpec("orca", shield="on"), CONFIG, robot)).__name__ == "Shield"
    assert type(make(ControllerSpec("gpc", shield="off"), CONFIG, robot)).__name__ == "GPCController"
    assert ControllerSpec("orca", shield="on").label == "orca[shield=on]"
    assert ControllerSpec("gpc", shield="on").label == "gpc"
    # nn is what a robot deploys: the planner-free check, its way out searched; the network's
    # roll-out is judged there and with the GPC on standby (shield mode gpc)
    standby = make(ControllerSpec("nn", shield="gpc"), CONFIG, robot)
    assert made["nn"].filter.fallback is None and made["nn"].filter.search_way_out
    assert standby.filter.fallback is not None and not standby.filter.search_way_out
    assert made["nn"]._rollout is not None and standby._rollout is not None and made["gpc"]._rollout is None
    # ... and passes when it keeps the margin for the measured trust time; nothing else has one
    from casadi_gpc.safety import ROLLOUT_TRUST_S
    assert made["nn"].filter.trust_rollout_s == standby.filter.trust_rollout_s == ROLLOUT_TRUST_S == 4.5
    assert made["gpc"].filter.trust_rollout_s is None
    assert ControllerSpec("nn").label == "nn" and ControllerSpec("nn", shield="gpc").label == "nn[shield=gpc]"


def test_shield_keeps_the_network_s_deployed_check():
    """``--shield`` asks for the check layer, which gpc and nn run behind by default: for nn
    the planner-free check a robot deploys; ``--shield-fallback gpc`` puts the GPC on standby
    behind it (mode ``gpc``)."""
    import argparse

    from gpcnav.controllers import shield_mode

    def mode(kind, shield=None, fallback=None):
        return shield_mode(argparse.Namespace(shield=shield, shield_fallback=fallback), kind)

    assert mode("nn") == mode("nn", "on") == "on"
    assert mode("nn", "on", "brake") == mode("nn", None, "brake") == "on"
    assert mode("nn", "on", "gpc") == mode("nn", None, "gpc") == "gpc"
    assert mode("nn", "off") == "off" and mode("nn", "off", "gpc") == "off"
    assert mode("gpc", "on") == mode("gpc") == "on"
    assert mode("orca") == "off" and mode("orca", "on") == "on" and mode("orca", "on", "gpc") == "gpc"


def test_options_of_the_network_are_refused_for_another_controller(tmp_path):
    with pytest.raises(UsageError, match="options of --controller nn"):
        check(ControllerSpec("orca", model=tmp_path / "m.onnx"), CONFIG, RobotParams())


def test_a_user_class_from_outside_the_project_runs_in_simulate_and_evaluate(outside):
    r = _cli(outside, "simulate", "empty.toml", "--controller", "mymod:MyPolicy", "--out", "run.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((outside / "run.json").read_text())
    check_run_document(doc)
    # known answer: 0.4 m/s is reached in the first interval (0.8 m/s^2 x 0.5 s), so the
    # robot is on the reference point all the way and reaches the end at 10 s
    assert doc["controller"] == "mymod:MyPolicy" and doc["outcome"] == "reached_goal"
    assert doc["time_to_goal_s"] == pytest.approx(10.0) and doc["tracking_rmse_m"] < 1e-9
    assert doc["controller_settings"]["class"] == "mymod.MyPolicy"
    # two worker processes, each making the class itself
    r = _cli(outside, "evaluate", "empty.toml", "empty.toml", "--controller", "mymod:MyPolicy", "--workers", "2",
             "--out", "eval.json")
    assert r.returncode == 0, r.stderr
    ev = json.loads((outside / "eval.json").read_text())
    assert ev["controller"] == "mymod:MyPolicy" and ev["success_rate"] == 1.0 and ev["episodes"] == 2
    # (one file twice: two episodes, and a line says so)
    assert "gpcnav evaluate: empty.toml given more than once: each run counts" in r.stderr


def test_a_name_of_no_controller_in_compare_s_list_is_named_as_compare_s_option(outside):
    """It was said to be --controller's, an option compare was not given."""
    r = _cli(outside, "compare", "empty.toml", "--controllers", "stand,NN", "--workers", "1", timeout=120)
    assert r.returncode == 2 and r.stderr.startswith("gpcnav compare: error: --controllers 'NN': not a controller")


@pytest.mark.parametrize("name, message", [
    ("nosuchmodule:MyPolicy", "cannot import module 'nosuchmodule'"),
    ("mymod:Missing", "module 'mymod' has no class 'Missing'"),
    ("mymod:NoDecide", "does not answer the Policy protocol (no decide method"),
    ("mymod:NeedsArguments", "cannot be made with no arguments"),
    # (a traceback, exit 1)
    ("mymod:SampleTimeRaises", "reading its Policy protocol raised RuntimeError: no clock yet"),
    ("nonsense", "not a controller"),
])
def test_a_controller_that_cannot_be_loaded_exits_2_with_one_line(outside, name, message):
    r = _cli(outside, "simulate", "empty.toml", "--controller", name, timeout=120)
    assert r.returncode == 2, r.stderr
    assert message in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and r.stdout == ""


@pytest.mark.parametrize("argv", [
    ["simulate", "empty.toml", "--controller", "mymod:ReturnsTuple"],
    ["simulate", "empty.toml", "--controller", "mymod:ReturnsTuple", "--shield"],
    ["evaluate", "empty.toml", "empty2.toml", "--controller", "mymod:ReturnsTuple", "--workers", "2", "--out", "e.json"],
    ["compare", "empty.toml", "--controllers", "stand,mymod:ReturnsTuple", "--workers", "1", "--out", "c.json"],
])  # --out: the finished episodes kept beside it, not in the shared cache (another run's would be reused)
def test_a_decide_that_does_not_return_a_control_decision_exits_2_with_one_line(outside, argv):
    """It failed as an AttributeError deep in the simulator (or the check layer), exit 1."""
    r = _cli(outside, *argv, timeout=120)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip() == (f"gpcnav {argv[0]}: error: mymod.ReturnsTuple.decide() returned a tuple, not a "
                                f"casadi_gpc.ControlDecision (the Policy protocol)")


@pytest.mark.parametrize("argv, where", [
    (["simulate", "long.toml", "--controller", "mymod:RaisesOnALongLine"], ""),
    (["simulate", "long.toml", "--controller", "mymod:RaisesOnALongLine", "--shield"], ""),
    (["evaluate", "empty.toml", "long.toml", "--controller", "mymod:RaisesOnALongLine", "--workers", "1", "--out",
      "e.json"], " (in long.toml); what finished before is kept"),
    (["compare", "empty.toml", "long.toml", "--controllers", "stand,mymod:RaisesOnALongLine", "--workers", "1", "--out",
      "c.json"], " (in long.toml); what finished before is kept"),
])
def test_a_user_s_controller_that_raises_exits_2_with_one_line_and_keeps_finished_episodes(outside, argv, where):
    """A user's decide() raising ended the command in a traceback (exit 1); now one line naming
    the class, the instant and the error, and the episodes finished before it are kept."""
    (outside / "long.toml").write_text(straight_line_toml("long_line", duration_s=20.0, line_m=6.0), encoding="utf-8")
    r = _cli(outside, *argv, timeout=120)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip() == (f"gpcnav {argv[0]}: error: --controller mymod:RaisesOnALongLine: decide() raised at "
                                f"t = 2 s: RuntimeError: sensor glitch{where}")
    if argv[0] != "simulate":
        stored = [json.loads(p.read_text()) for p in (outside / f"{argv[-1]}.episodes").glob("*.json")]
        # the short line's episode (and the robot standing still on both) finished and kept
        expected = {("empty_line", "mymod:RaisesOnALongLine")} | (
            {("empty_line", "stand"), ("long_line", "stand")} if argv[0] == "compare" else set())
        assert {(d["scenario"], d["controller"]) for d in stored} == expected


def test_a_user_s_reset_that_raises_exits_2_with_one_line(outside):
    r = _cli(outside, "simulate", "empty.toml", "--controller", "mymod:RaisesInReset", timeout=120)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip() == ("gpcnav simulate: error: --controller mymod:RaisesInReset: reset() raised "
                                "KeyError: 'calibration'")


def test_a_user_s_class_is_described_and_answers_as_itself(outside, monkeypatch):
    """The commands' guard around a user's class forwards its attributes and names the class
    itself in the documents."""
    from gpcnav.controllers import UserController, describe
    monkeypatch.syspath_prepend(str(outside))
    made = make(ControllerSpec("mymod:MyPolicy"), CONFIG, RobotParams())
    assert isinstance(made, UserController) and type(made.wrapped).__name__ == "MyPolicy"
    made.reset()
    assert made.decisions == 0 and made.sample_time_s == 0.5
    assert describe(made)["class"] == "mymod.MyPolicy"
    assert describe(make(ControllerSpec("mymod:MyPolicy", shield="on"), CONFIG, RobotParams()))["class"] == "mymod.MyPolicy"


def test_the_readme_s_example_policy_runs_bare_and_behind_the_shield(tmp_path):
    """The README's example, copied out of the README into a module outside the project:
    alone it follows the path into the crossing obstacle of Fig. 7.2; behind the shield it
    reaches the goal."""
    readme = (REPO / "README.md").read_text(encoding="utf-8")
    i = readme.index("class MyPolicy")
    start, end = readme.rindex("```python", 0, i) + len("```python"), readme.index("```", i)
    assert len(readme[start:end].strip().splitlines()) <= 20
    (tmp_path / "mymod.py").write_text(readme[start:end], encoding="utf-8")
    fig = REPO / "scenarios" / "paper" / "fig7_2_crossing.toml"
    outcomes = []
    for shield in ([], ["--shield"]):
        r = _cli(tmp_path, "simulate", fig, "--controller", "mymod:MyPolicy", *shield, "--out", "run.json")
        assert r.returncode == 0, r.stderr
        doc = json.loads((tmp_path / "run.json").read_text())
        outcomes.append((doc["outcome"], doc["shield"], doc["interventions"] > 0))
    assert outcomes == [("collided", "off", False), ("reached_goal", "on", True)]


def test_the_planner_on_standby_behind_a_controller_of_another_rate_is_refused_before_any_work():
    """orca (0.1 s) with --shield-fallback gpc (0.5 s) stopped at its first intervention with a
    shape error; a controller at the planner's rate keeps the standby."""
    with pytest.raises(UsageError, match="orca decides every 0.1 s and the planner on standby every 0.5 s"):
        check(ControllerSpec("orca", shield="gpc"), CONFIG, RobotParams())
    with pytest.raises(UsageError, match="the check needs one rate"):
        make(ControllerSpec("social_force", shield="gpc"), CONFIG, RobotParams())
    check(ControllerSpec("blind", shield="gpc"), CONFIG, RobotParams())
    check(ControllerSpec("orca", shield="on"), CONFIG, RobotParams())


def test_a_controller_named_twice_in_a_comparison_is_refused():
    """It was dropped silently: a one-row table where two rows were asked for."""
    from gpcnav.controllers import parse_controller_list
    with pytest.raises(UsageError, match="gpc given twice"):
        parse_controller_list("gpc,orca,gpc")
    assert parse_controller_list("gpc, orca") == ["gpc", "orca"]


@pytest.mark.parametrize("text", ["nn,", "nn,,stand", ",nn", "nn, ,stand"])
def test_an_empty_name_in_a_comparison_s_list_is_refused(text):
    """It was skipped: 'nn,' (a name left out, a shell variable unset) ran nn alone, unsaid;
    bench --solvers and train --parts skipped theirs too (one rule, gpcnav.errors.comma_items)."""
    from gpcnav.commands.bench import parse_solvers
    from gpcnav.controllers import parse_controller_list
    with pytest.raises(UsageError, match="--controllers .*: an empty item between commas"):
        parse_controller_list(text)
    with pytest.raises(UsageError, match="--solvers .*: an empty item between commas"):
        parse_solvers(text.replace("nn", "ipopt").replace("stand", "fatrop"))


def test_an_evaluation_records_a_peer_s_own_sample_time(outside):
    r = _cli(outside, "evaluate", "empty.toml", "--controller", "orca", "--workers", "1", "--out", "e.json")
    assert r.returncode == 0, r.stderr
    doc = json.loads((outside / "e.json").read_text())
    assert doc["sample_time_s"] == doc["controller_settings"]["sample_time_s"] == pytest.approx(0.1)


@pytest.mark.parametrize("argv, words", [
    (["simulate", "{f}", "--controller", "stand", "--shield-fallback", "brake"], "stand runs bare unless --shield"),
    (["evaluate", "{f}", "--controller", "blind", "--shield-fallback", "gpc", "--workers", "1"],
     "blind runs bare unless --shield"),
    (["simulate", "{f}", "--controller", "nn", "--no-shield", "--shield-fallback", "gpc"], "--no-shield"),
    (["compare", "{f}", "--controllers", "stand,blind", "--shield-fallback", "gpc", "--workers", "1"],
     "stand, blind run bare unless --shield"),
])
def test_a_shield_fallback_no_controller_runs_behind_is_refused(tmp_path, capsys, argv, words):
    """``--shield-fallback`` for a controller that runs bare (a peer, a baseline or a user's class without
    ``--shield``; ``--no-shield``) was dropped without a word, and the refusal of unread planner settings
    advised it: ``--controller stand --horizon 8 --shield-fallback gpc`` was refused with the same advice."""
    from gpcnav.cli import main
    f = tmp_path / "empty.toml"
    f.write_text(EMPTY, encoding="utf-8")
    code = main([a.replace("{f}", str(f)) for a in argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--shield-fallback" in err[0] and words in err[0], err


def test_the_advice_for_unread_planner_settings_is_one_that_runs(tmp_path, capsys):
    from gpcnav.cli import main
    f = tmp_path / "empty.toml"
    f.write_text(EMPTY, encoding="utf-8")
    assert main(["simulate", str(f), "--controller", "stand", "--horizon", "8"]) == 2
    assert "put the planner on standby with --shield --shield-fallback gpc" in capsys.readouterr().err


SETTINGS_MODULE = textwrap.dedent('''
    from dataclasses import dataclass, field
    from pathlib import Path

    import numpy as np

    from casadi_gpc import ControlDecision

    @dataclass
    class Settings:
        model: Path = Path("weights") / "net.onnx"
        gains: np.ndarray = field(default_factory=lambda: np.array([0.5, 1.5]))
        step: np.float32 = np.float32(0.25)
        cap: float = float("inf")

    class Tuned:
        sample_time_s = 0.5

        def __init__(self):
            self.settings = Settings()

        def reset(self):
            pass

        def decide(self, observation):
            v = observation.reference.speed_mps
            return ControlDecision(v, v)
''')


def test_a_user_class_s_settings_of_any_type_are_recorded_in_the_documents(outside):
    """A user's class whose ``settings`` dataclass holds a Path (an array, a numpy scalar, an infinity) ran
    every episode, then stopped writing RUN.json / EVAL.json with a traceback (TypeError: not JSON
    serialisable: PosixPath), exit 1; the documents record such settings as JSON data."""
    (outside / "tuned.py").write_text(SETTINGS_MODULE, encoding="utf-8")
    r = _cli(outside, "simulate", "empty.toml", "--controller", "tuned:Tuned", "--out", "run.json")
    assert r.returncode == 0, r.stderr
    settings = json.loads((outside / "run.json").read_text())["controller_settings"]["settings"]
    assert settings == {"model": os.path.join("weights", "net.onnx"), "gains": [0.5, 1.5], "step": 0.25, "cap": "inf"}
    r = _cli(outside, "evaluate", "empty.toml", "--controller", "tuned:Tuned", "--workers", "1", "--out", "eval.json")
    assert r.returncode == 0, r.stderr
    assert json.loads((outside / "eval.json").read_text())["controller_settings"]["settings"] == settings


WORDS_MODULE = textwrap.dedent('''
    import numpy as np

    from casadi_gpc import ControlDecision

    class Base:
        sample_time_s = 0.5

        def reset(self):
            pass

    class Word(Base):
        def decide(self, observation):
            return ControlDecision("fast", 0.3)

    class Array(Base):
        def decide(self, observation):
            return ControlDecision(np.array([0.3]), np.array([0.3]))

    class Nothing(Base):
        def decide(self, observation):
            return ControlDecision(None, 0.3)

    class Numpy(Base):
        def decide(self, observation):
            return ControlDecision(np.float32(0.3), np.int64(0))
''')


@pytest.mark.parametrize("name, shown, shield", [("Word", "'fast' (a str)", []),
                                                 ("Array", "array([0.3]) (a ndarray)", ["--shield"]),
                                                 ("Nothing", "None (a NoneType)", [])])
def test_a_decision_whose_wheel_speeds_are_not_numbers_exits_2_with_one_line(outside, name, shown, shield):
    """A user's ControlDecision("fast", 0.3) (or arrays for numbers) failed deep in the simulator with a
    traceback, exit 1 ("could not convert string to float"); None was taken as NaN and braked for, silently."""
    (outside / "words.py").write_text(WORDS_MODULE, encoding="utf-8")
    r = _cli(outside, "simulate", "empty.toml", "--controller", f"words:{name}", *shield, timeout=120)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip() == (f"gpcnav simulate: error: words.{name}.decide() returned a ControlDecision whose "
                                f"v_right_mps is {shown}, not a number of m/s (the Policy protocol)")
    if name == "Nothing":  # (each case a subprocess or two: the numpy one, bare and shielded, in the others)
        return
    r = _cli(outside, "simulate", "empty.toml", "--controller", "words:Numpy", *shield, timeout=120)
    assert r.returncode == 0, r.stderr  # numpy's numbers are numbers
