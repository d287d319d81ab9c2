"""The check layer's one settings object (casadi_gpc.safety.CheckSettings) and the registry
that declares it per controller (gpcnav.controllers.REGISTRY)."""
from __future__ import annotations

import math

import pytest

from casadi_gpc.config import preset
from casadi_gpc.robot import RobotParams
from casadi_gpc.safety import ROLLOUT_TRUST_S, SAFER_ALTERNATIVES, CheckSettings, Shield
from gpcnav.controllers import DEFAULT_SHIELD, REGISTRY, WALLS_CHECK_MARGIN_M, check_settings


@pytest.mark.parametrize("bad, words", [
    (dict(fallback="gpc"), "fallback must be one of"),
    (dict(trust_planner_s=-1.0), "trust_planner_s"),
    (dict(rollouts=True, trust_rollout_s=float("nan")), "trust_rollout_s"),
    (dict(margin_m=-0.1), "margin_m"),
    (dict(substeps=0), "substeps"),
    (dict(horizon=0), "horizon"),
    (dict(safer_alternatives=True), "set trust_plans too"),
    (dict(trust_rollout_s=3.0), "set rollouts too"),
    (dict(search_near_walls=True), "search_near_walls needs search"),
    (dict(walls_margin_m=0.02), "go together"),
    (dict(walls_sigmas=1.0), "go together"),
    (dict(walls_margin_m=-0.01, walls_sigmas=1.0), "walls_margin_m must be finite"),
    (dict(walls_margin_m=0.02, walls_sigmas=math.inf), "walls_sigmas must be finite"),
    # taken until 2026-12-02, and failed only when the check was built (NaN: "cannot convert float NaN")
    (dict(substeps=math.nan), "substeps must be a whole number"),
    (dict(substeps=2.5), "substeps must be a whole number"),
    (dict(horizon=math.nan), "horizon must be a whole number"),
    (dict(horizon=1.5), "horizon must be a whole number"),
    # a string or a bool read as a number (until 2026-12-02 a string failed inside math.isfinite, a TypeError
    # naming no field, and True passed as 1.0): the one rule for a number, casadi_gpc.finite.finite_real
    (dict(margin_m="0.05"), "margin_m must be finite"),
    (dict(sigmas=True), "sigmas must be finite"),
    (dict(trust_planner_s="3"), "trust_planner_s must be finite"),
    (dict(walls_margin_m=0.02, walls_sigmas="1"), "walls_sigmas must be finite"),
])
def test_bad_settings_are_refused(bad, words):
    with pytest.raises(ValueError, match=words):
        CheckSettings(**bad)


def test_settings_are_frozen_and_hashable():
    s = CheckSettings(trust_plans=True)
    with pytest.raises(AttributeError):
        s.trust_plans = False
    assert hash(s) == hash(CheckSettings(trust_plans=True))


class _Net:
    """A one-command network with a roll-out (as OnnxPolicy is to the registry)."""
    outputs_plans = False


class _PlanNet:
    outputs_plans = True


@pytest.mark.parametrize("name", ["paper", "improved"])
def test_the_registry_declares_what_each_controller_is_trusted_with(name):
    cfg = preset(name)
    gpc = check_settings("gpc", object(), cfg, "on")
    assert gpc.trust_plans and gpc.fallback == "manoeuvres" and not gpc.rollouts
    assert gpc.safer_alternatives is SAFER_ALTERNATIVES[name]
    # robust drive-ins were taken back (docs/data/deploy/robust_drive_in/rule.md); the searched way
    # out and the near-walls margin apply only near walls, where the preset has a margin there
    # (docs/data/buildings/walls_margin/rule3.md)
    assert not gpc.robust_drive_in
    assert gpc.robust_drive_ties  # as a tie-break it was adopted (docs/data/pedestrians/robust_ties/rule.md)
    if cfg.walls_margin_m is None:
        assert not gpc.search and not gpc.search_two_phase and gpc.walls_margin_m is None
    else:
        assert gpc.search and gpc.search_two_phase and gpc.search_near_walls
        assert (gpc.walls_margin_m, gpc.walls_sigmas) == (WALLS_CHECK_MARGIN_M, cfg.walls_sigmas)
    assert (name == "improved") == (cfg.walls_margin_m is not None)
    assert check_settings("gpc", object(), cfg, "gpc") == gpc        # its own alternatives come first
    nn = check_settings("nn", _Net(), cfg, "gpc")
    assert nn.rollouts and nn.trust_rollout_s == ROLLOUT_TRUST_S and nn.fallback == "planner"
    assert not nn.trust_plans and not nn.safer_alternatives
    assert not nn.search                                               # the standby planner, not the search
    bare = check_settings("nn", _Net(), cfg, "on")                     # the planner-free check, deployed
    assert bare.rollouts and bare.trust_rollout_s == ROLLOUT_TRUST_S and bare.fallback == "manoeuvres"
    assert bare.search and not bare.trust_plans
    assert bare.robust_drive_ties and not bare.robust_drive_in  # adopted by nn_rule.md (docs/data/pedestrians/robust_ties/)
    plans = check_settings("nn", _PlanNet(), cfg, "on")
    assert plans.trust_plans and plans.previous_plan and not plans.rollouts and plans.search
    for peer in ("orca", "hrvo", "social_force", "mppi", "stand", "blind", "mymod:Mine"):
        assert check_settings(peer, object(), cfg, "on") == CheckSettings()
        assert check_settings(peer, object(), cfg, "gpc") == CheckSettings(fallback="planner")
    assert DEFAULT_SHIELD == {n: k.default_shield for n, k in REGISTRY.items()}
    assert DEFAULT_SHIELD["gpc"] == "on" and DEFAULT_SHIELD["nn"] == "on" and DEFAULT_SHIELD["orca"] == "off"


class _Scripted:
    sample_time_s = 0.5

    def reset(self):
        pass

    def decide(self, obs):
        raise AssertionError("not called here")


def test_shield_takes_its_flags_from_the_settings():
    s = CheckSettings(margin_m=0.2, sigmas=1.0, substeps=3, horizon=7, trust_planner_s=2.0)
    sh = Shield(_Scripted(), RobotParams(), s)
    assert sh.settings is s and sh.horizon == 7 and sh.filter.fallback is None
    assert (sh.filter.margin_m, sh.filter.sigmas, sh.filter.substeps, sh.filter.trust_planner_s) == (0.2, 1.0, 3, 2.0)
    with pytest.raises(ValueError, match="planner_config"):
        Shield(_Scripted(), RobotParams(), CheckSettings(fallback="planner"))
    with pytest.raises(ValueError, match="not 'planner'"):
        Shield(_Scripted(), RobotParams(), CheckSettings(), standby=_Scripted())


def test_the_faults_page_shield_snippets_construct():
    """docs/faults.md's inline ``Shield(...)`` and ``CheckSettings(...)`` forms are made as
    written (``GPCController(...)`` taken as the improved preset's, ``=...`` as True): the page
    showed keywords the Shield had lost (``fallback=``, ``rollouts=``, ``previous_plan=``)."""
    import re
    from pathlib import Path

    from casadi_gpc.planner.gpc import GPCController
    from casadi_gpc.safety import StandbyPlanner  # noqa: F401  (a name the snippets may use)
    from nn_export import OnnxPolicy  # noqa: F401

    text = (Path(__file__).resolve().parents[1] / "docs" / "faults.md").read_text(encoding="utf-8")
    spans = [" ".join(s.split()) for s in re.findall(r"`((?:Shield|CheckSettings)\([^`]*\))`", text)]
    assert len(spans) >= 5, spans
    names = dict(globals(), GPCController=GPCController, StandbyPlanner=StandbyPlanner, OnnxPolicy=OnnxPolicy,
                 policy=OnnxPolicy())
    for span in spans:
        code = span.replace("(...)", '(preset("improved"))').replace("=...", "=True")
        made = eval(code, names)  # noqa: S307 (the page's own code)
        assert isinstance(made, (Shield, CheckSettings)), span
