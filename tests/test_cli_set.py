"""``--set NAME=VALUE``: any planner setting from the command line, checked before any work
(an unknown name, a value of another type, one the settings refuse: one line, exit 2), and
recorded in the documents (``planner_changes``) so a result says what it was run with."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from casadi_gpc.config import preset
from conftest import PAPER_DIR
from gpcnav.commands.common import config_differences, for_run, planner_changes, with_settings
from gpcnav.errors import UsageError

IMPROVED = preset("improved")


def test_values_are_read_as_the_setting_s_type():
    cfg = with_settings(IMPROVED, ["clearance_margin_m=0.2", "cold_starts=2", "walls_directional_sigma=true",
                                   "beyond_horizon_s=1,2.5", "walls_sigma_cap_m=none", "forecast=turn",
                                   "influence_m=2", "guesses=brake, straight"])
    assert cfg.clearance_margin_m == 0.2 and cfg.cold_starts == 2 and cfg.walls_directional_sigma is True
    assert cfg.beyond_horizon_s == (1.0, 2.5) and cfg.walls_sigma_cap_m is None and cfg.forecast == "turn"
    assert cfg.influence_m == 2.0 and isinstance(cfg.influence_m, float) and cfg.guesses == ("brake", "straight")
    assert with_settings(IMPROVED, []) is IMPROVED
    assert planner_changes(cfg) == {"clearance_margin_m": 0.2, "cold_starts": 2, "walls_directional_sigma": True,
                                    "beyond_horizon_s": (1.0, 2.5), "forecast": "turn", "influence_m": 2.0,
                                    "guesses": ("brake", "straight")}


@pytest.mark.parametrize("item, words", [
    ("nonsense=1", "not a planner setting"),
    ("name=other", "not a planner setting"),
    ("horizon=abc", "expected int"),
    ("walls_directional_sigma=1.5", "expected bool"),
    ("clearance_margin_m=nan", "must be finite"),
    ("beyond_horizon_s=1,x", "comma-separated numbers"),
    ("forecast=zigzag", "forecast must be one of"),
    ("walls_sigma_cap_m=-1", "walls_sigma_cap_m must be finite"),
    ("max_walls=3", "adapted to each run"),
    ("cold_starts", "NAME=VALUE"),
    # numbers no planner is built or run with: they crashed inside CasADi or IPOPT (after a
    # compile), or ran with a negative weight
    ("horizon=0", "horizon must be a whole number of at least 1"),
    ("horizon=-3", "horizon must be a whole number of at least 1"),
    ("sample_time_s=0", "sample_time_s must be finite and above 0 s"),
    ("sample_time_s=-0.5", "sample_time_s must be finite and above 0 s"),
    ("lambda1=-63", "lambda1 must be finite and not negative"),
    ("goal_weight=-1", "goal_weight must be finite and not negative"),
    ("influence_m=-1", "influence_m must be above 0"),
    ("uncertainty_sigmas=-2", "uncertainty_sigmas must not be negative"),
    ("solve_lanes=0", "solve_lanes must be a whole number of at least 1"),
    ("max_moving=-1", "max_moving must be a whole number of at least 0"),
    # names the planner refused only when it was made, in a traceback (exit 1)
    ("solver=bogus", "unknown solver 'bogus'"),
    ("candidates=bogus", "candidates must be one of persistent, multistart"),
    ("guesses=straight,bogus", "unknown initial guesses"),
    ("guesses=", "give at least one initial guess"),  # (the planner never solved: the robot stood all run)
    ("cold_starts=1 cold_starts=2", "cold_starts: given twice"),  # (the last ran, the first was said nowhere)
    # an item left out between commas was skipped: 1,,2 ran as 1,2
    ("beyond_horizon_s=1,,2", "beyond_horizon_s '1,,2': an empty item between commas"),
    ("guesses=straight,", "guesses 'straight,': an empty item between commas"),
])
def test_bad_settings_are_refused_in_one_line(item, words):
    with pytest.raises(UsageError, match=words):
        with_settings(IMPROVED, item.split(" "))


def test_a_solver_s_alias_is_read_as_its_name_as_with_the_solver_option():
    """--set solver=ipopt is --solver ipopt: the same configuration, the same changes recorded."""
    assert with_settings(IMPROVED, ["solver=ipopt"]).solver == "ipopt-warm"


def test_the_command_line_s_bounds_hold_for_a_value_given_with_set():
    """--set horizon=50 is refused as --horizon 50 is (the compile grows steeply with H)."""
    import argparse
    from gpcnav.commands.common import planner_config
    base = dict(preset="improved", sample_time=None, horizon=None, solver=None)
    with pytest.raises(UsageError, match="horizon must be at most"):
        planner_config(argparse.Namespace(**base, planner_set=["horizon=50"]))
    with pytest.raises(UsageError, match="sample_time_s must be at least"):
        planner_config(argparse.Namespace(**base, planner_set=["sample_time_s=0.001"]))
    assert planner_config(argparse.Namespace(**base, planner_set=["horizon=8"])).horizon == 8


def test_what_a_run_adapts_is_not_a_change():
    """The wall slots and the crowd NLP that a run sets for its scenarios are not recorded as
    changes; an overridden sample time is."""
    class Walls:
        walls = ((0.0, 0.0), (1.0, 0.0))
        moving = ()
    assert planner_changes(for_run(IMPROVED, [Walls()])) == {}
    assert planner_changes(IMPROVED.with_overrides(sample_time_s=0.25)) == {"sample_time_s": 0.25}


def _gpcnav(*argv):
    return subprocess.run([sys.executable, "-m", "gpcnav", *map(str, argv)], capture_output=True, text=True,
                          timeout=300)


def test_the_command_line_sets_records_and_refuses(tmp_path):
    scenario = PAPER_DIR / "fig7_2_crossing.toml"
    proc = _gpcnav("simulate", scenario, "--controller", "gpc", "--set", "horizon=abc")
    assert proc.returncode == 2 and proc.stderr.strip() == "gpcnav simulate: error: --set horizon: expected int, got 'abc'"
    runs = {}
    for label, extra in (("plain", []), ("wide", ["--set", "uncertainty_scale_m=0.1"])):
        out = tmp_path / f"{label}.json"
        proc = _gpcnav("simulate", scenario, "--controller", "gpc", "--out", out, *extra)
        assert proc.returncode == 0, proc.stderr
        runs[label] = json.loads(out.read_text())
    assert "planner_changes" not in runs["plain"]
    assert runs["wide"]["planner_changes"] == {"uncertainty_scale_m": 0.1}
    from gpcnav.commands.common import usable_cores
    lanes = min(2, usable_cores())  # one process: the preset's two, or the cores there are
    assert runs["plain"]["solve_lanes"] == runs["wide"]["solve_lanes"] == lanes
    assert runs["wide"]["trajectory"]["y"] != runs["plain"]["trajectory"]["y"]  # the setting reached the planner


def test_settings_a_controller_does_not_read_are_refused_or_recorded_as_unused(tmp_path):
    """A planner setting given to a controller that does not read it (the network, which runs
    at its model's settings behind the planner-free check; a navground peer; a baseline) did
    nothing: alone, it is refused in one line before any work; in a comparison beside one that
    reads it, that controller's document records it as ``planner_changes_unused``, not as a
    change it was run with."""
    from gpcnav.commands.common import refuse_unread_changes
    from gpcnav.controllers import ControllerSpec, reads_planner_settings
    assert reads_planner_settings(ControllerSpec("gpc")) and reads_planner_settings(ControllerSpec("mppi"))
    assert not any(reads_planner_settings(ControllerSpec(n)) for n in ("nn", "orca", "hrvo", "social_force", "stand",
                                                                       "blind", "my.module:Policy"))
    # the GPC on standby behind the check reads them, for any controller
    assert reads_planner_settings(ControllerSpec("nn", shield="gpc"))
    assert reads_planner_settings(ControllerSpec("orca", shield="gpc"))
    wide = IMPROVED.with_overrides(clearance_margin_m=0.3)
    assert refuse_unread_changes([ControllerSpec("nn")], IMPROVED) == []  # nothing changed: nothing to say
    assert refuse_unread_changes([ControllerSpec("gpc"), ControllerSpec("nn")], wide) == [ControllerSpec("nn")]
    with pytest.raises(UsageError, match="clearance_margin_m: .*none of nn, stand reads"):
        refuse_unread_changes([ControllerSpec("nn"), ControllerSpec("stand")], wide)
    with pytest.raises(UsageError, match="sample_time_s: .*which --controller orca does not read"):
        refuse_unread_changes([ControllerSpec("orca")], IMPROVED.with_overrides(sample_time_s=0.25))
    out = tmp_path / "refused.json"  # the command line: one line, exit 2, nothing written
    proc = _gpcnav("evaluate", "--suite", "random", "--count", "1", "--controller", "nn", "--horizon", "8", "--out", out)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip().splitlines() == [
        "gpcnav evaluate: error: horizon: planner settings (--set, --sample-time, --horizon, --solver), which "
        "--controller nn does not read (a network runs at its model's settings, a peer at its own); drop them, or "
        "put the planner on standby with --shield --shield-fallback gpc"]
    assert not out.exists()
    out = tmp_path / "C.json"
    proc = _gpcnav("compare", "--suite", "random", "--count", "1", "--seed", "1", "--controllers", "gpc,stand",
                   "--set", "clearance_margin_m=0.3", "--workers", "1", "--out", out)
    assert proc.returncode == 0, proc.stderr
    assert "stand does not read the planner settings given (clearance_margin_m)" in proc.stderr
    gpc, stand = json.loads(out.read_text())["controllers"]
    assert gpc["planner_changes"] == {"clearance_margin_m": 0.3} and "planner_changes_unused" not in gpc
    assert stand["planner_changes_unused"] == {"clearance_margin_m": 0.3} and "planner_changes" not in stand


def test_settings_recorded_before_they_existed_are_taken_at_their_default():
    """A dataset's manifest written before a setting existed still matches the settings of
    today's preset (``gpcnav train``, a DAgger round), and a real change still shows."""
    now = IMPROVED.to_dict()
    old = {k: v for k, v in now.items() if k not in ("walls_directional_sigma", "walls_sigma_cap_m")}
    assert config_differences(old, now) == []
    assert config_differences(old, {**now, "walls_directional_sigma": True}) == ["walls_directional_sigma"]
    assert config_differences(now, {**now, "solver": "ipopt", "time_budget_s": 1.0}) == []  # how, not which NLP
    assert config_differences(now, {**now, "solve_lanes": 1}) == []  # how fast, not which NLP
    assert config_differences(now, {**now, "beyond_horizon_s": [1.0]}) == ["beyond_horizon_s"]
