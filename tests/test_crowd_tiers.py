"""The crowd NLP (``PlannerConfig.crowd_moving``, :mod:`casadi_gpc.planner.tiers`): solved
only at ticks where the controller tracks more movers than the preset's slots hold, the
same plans there as a controller whose one NLP has the crowd's slots, the same plans
elsewhere as a controller without it, and a warm start carried from one NLP to the other."""
from __future__ import annotations

import tomllib
from dataclasses import replace

import numpy as np
import pytest

casadi = pytest.importorskip("casadi")

from casadi_gpc.config import PlannerConfig, preset  # noqa: E402
from casadi_gpc.planner.gpc import GPCController  # noqa: E402
from casadi_gpc.planner.tiers import crowd_config, crowded  # noqa: E402
from casadi_gpc.problem.cost import build_problem  # noqa: E402
from conftest import straight_line_toml  # noqa: E402
from scenarios import scenario_from_dict  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402

# a short horizon and uncompiled functions: the test compiles nothing
SMALL = preset("improved").with_overrides(horizon=4, max_moving=2, crowd_moving=3)


def _mover(x: float, y: float, heading_deg: float, speed: float = 0.3) -> str:
    return (f"[[moving_obstacles]]\nposition = [{x}, {y}]\nheading_deg = {heading_deg}\n"
            f"speed_mps = {speed}\nradius_m = 0.3\n")


def _scenario(movers: str, duration_s: float = 4.0):
    return scenario_from_dict(tomllib.loads(straight_line_toml("tiers", duration_s, 4.0, movers)), "tiers.toml")


def _decisions(config: PlannerConfig, scenario):
    ctl = GPCController(config, scenario.robot, compile_solver=False)
    log = simulate(scenario, ctl, "gpc")
    return ctl, log.decisions


def test_the_crowd_settings():
    improved = preset("improved")
    assert improved.crowd_moving == 16 and improved.max_moving == 10
    crowd = crowd_config(improved)
    assert crowd.max_moving == 16 and crowd.crowd_moving is None
    assert crowd_config(preset("paper")) is None                       # the paper's planner: one NLP
    assert crowd_config(improved.with_overrides(max_moving=16)) is None  # no more slots than the first
    for bad in (0, 2.5, -3):
        with pytest.raises(ValueError, match="crowd_moving"):
            improved.with_overrides(crowd_moving=bad)


def test_crowded_counts_the_tracked_movers():
    class F:  # a forecast: only its count matters
        pass
    assert not crowded(SMALL, [F(), F()])
    assert crowded(SMALL, [F(), F(), F()])


def test_a_warm_start_fits_either_nlp():
    """The kept plans carry their increments and multipliers from one NLP to the other: the
    slots change the parameters and the cost, not the variables or the constraints."""
    small, crowd = build_problem(SMALL), build_problem(crowd_config(SMALL))
    assert crowd.layout.size > small.layout.size
    assert small.n_u == crowd.n_u
    np.testing.assert_array_equal(small.lbg, crowd.lbg)
    np.testing.assert_array_equal(small.ubg, crowd.ubg)
    np.testing.assert_array_equal(small.lbx, crowd.lbx)


def test_a_scene_within_the_slots_is_planned_as_without_the_crowd_nlp():
    sc = _scenario(_mover(2.5, -1.5, 90.0) + _mover(3.0, 1.5, -90.0))
    ctl, with_crowd = _decisions(SMALL, sc)
    _, without = _decisions(replace(SMALL, crowd_moving=None), sc)
    assert len(ctl._tiers) == 2 and "crowd_ticks" not in ctl.counters
    assert [(d.v_right_mps, d.v_left_mps) for d in with_crowd] == [(d.v_right_mps, d.v_left_mps) for d in without]


def test_a_crowd_is_planned_with_the_crowd_slots():
    """Three movers, two slots: every tick on the crowd NLP, the same wheel speeds as a
    controller whose one NLP has three slots, and none left out (the two-slot NLP leaves one)."""
    sc = _scenario(_mover(2.5, -1.5, 90.0) + _mover(3.0, 1.5, -90.0) + _mover(1.8, 1.2, -60.0))
    ctl, crowd = _decisions(SMALL, sc)
    _, wide = _decisions(replace(SMALL, max_moving=3, crowd_moving=None), sc)
    narrow_ctl, _ = _decisions(replace(SMALL, crowd_moving=None), sc)
    assert ctl.counters["crowd_ticks"] == len(crowd) > 0
    assert all(d.info.get("selected") == 3 for d in crowd if not d.fallback)
    assert [(d.v_right_mps, d.v_left_mps) for d in crowd] == [(d.v_right_mps, d.v_left_mps) for d in wide]
    assert ctl.counters["left_out"] == 0 and narrow_ctl.counters["left_out"] > 0


def test_the_plan_carries_over_when_the_crowd_comes_and_goes():
    """A third mover that is in the scene for a few seconds only: the crowd NLP while the
    controller tracks it, the first NLP before and after, every tick solved (no fallback),
    the kept plans warm-starting across the change."""
    passer = "[[moving_obstacles]]\nradius_m = 0.3\ntrack = [[1.5, 2.5, 1.8], [4.0, 2.5, -1.8]]\n"
    sc = _scenario(_mover(2.5, -1.5, 90.0) + _mover(3.0, 1.5, -90.0) + passer, duration_s=8.0)
    ctl, decisions = _decisions(SMALL, sc)
    crowd_ticks = ctl.counters.get("crowd_ticks", 0)
    assert 0 < crowd_ticks < len(decisions)
    assert not any(d.fallback for d in decisions)
    assert ctl.counters["failed_solves"] == 0


def test_a_run_without_crowds_builds_no_crowd_nlp():
    """The command line gives the planner the crowd NLP only for runs with a scene of more
    movers than the preset's slots (building it costs about a second a controller)."""
    from gpcnav.commands.common import for_run
    improved = preset("improved")
    assert improved.for_movers(10).crowd_moving is None
    assert improved.for_movers(11) is improved
    assert preset("paper").for_movers(50) is preset("paper")
    few = _scenario(_mover(2.5, -1.5, 90.0))
    many = _scenario("".join(_mover(2.0 + 0.7 * i, 3.0, -90.0) for i in range(11)))
    assert for_run(improved, [few]).crowd_moving is None
    assert for_run(improved, [few, many]).crowd_moving == 16
    ctl = GPCController(for_run(SMALL, [few]), few.robot, compile_solver=False)
    assert len(ctl._tiers) == 1
