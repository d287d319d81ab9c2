"""``interventions`` counts the decisions the check layer changed (CONTRACT.md), checked against
the decisions themselves: a candidate kept as the best of bad options (``no_safer_option``) is
not one (until 2026-12-02 it was counted; found by an audit)."""
import numpy as np
import pytest

pytest.importorskip("casadi")


def test_interventions_are_the_changed_decisions():
    from casadi_gpc.config import preset
    from gpcnav import controllers
    from gpcnav.commands.common import for_run
    from gpcnav.controllers import ControllerSpec
    from scenarios.metrics import episode_metrics
    from scenarios.simulator import simulate
    from scenarios.suites import Suite

    # a replayed UCY case in which the check keeps the GPC's own answer three times (none safer)
    sc = Suite("ucy", count=3, seed=1, behaviour="replay").scenario(2)
    ctl = controllers.make(ControllerSpec("gpc"), for_run(preset("improved"), [sc]), sc.robot)
    log = simulate(sc, ctl, "gpc")
    changed = 0
    for d in log.decisions:
        own = d.info.get("controller_wheels_mps")
        if own is not None and not np.allclose(own, (d.v_right_mps, d.v_left_mps), rtol=0.0, atol=1e-12):
            changed += 1
    assert log.events["shield_no_safer_option"] > 0  # the case still exercises a kept candidate
    assert log.events["interventions"] == changed
    assert episode_metrics(log).interventions == changed
