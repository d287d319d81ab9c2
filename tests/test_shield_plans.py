"""A user's class behind the check layer that hands over its own plan (``planned_wheels_mps``):
the check judges it over the check's horizon, the class's ``horizon`` (else 6 s of its samples).
A plan of another length (a class planning 3 s ahead with no ``horizon`` said) failed at the first
decision deep in the check ("candidate wheel speeds must have shape (2,) or (12, 2)"), and a plan
of one dimension or none with an IndexError; now one line naming the class, the shape and the
horizon (a :class:`~casadi_gpc.types.ProtocolError`, the command line's exit 2)."""
from __future__ import annotations

import numpy as np
import pytest

from casadi_gpc import ControlDecision, Observation, ReferencePath, RobotState, Segment
from casadi_gpc.safety import CheckSettings, Shield
from casadi_gpc.types import ProtocolError

REF = ReferencePath((0.0, 0.0), 0.0, (Segment.line(10.0),), 0.4)


class Planner:
    sample_time_s = 0.5

    def __init__(self, shape, horizon=None):
        self.shape = shape
        if horizon is not None:
            self.horizon = horizon

    def reset(self) -> None:
        pass

    def decide(self, observation) -> ControlDecision:
        return ControlDecision(0.4, 0.4, planned_wheels_mps=np.full(self.shape, 0.4))


def _decide(shield):
    return shield.decide(Observation(0.0, RobotState(0.0, 0.0, 0.0), REF))


@pytest.mark.parametrize("shape", [(6, 2), (20, 2), (12,), (2,), (12, 3), (0, 2)])
@pytest.mark.parametrize("trust", [False, True])
def test_a_plan_not_of_the_checks_horizon_is_refused_in_one_line(shape, trust):
    shield = Shield(Planner(shape), settings=CheckSettings(trust_plans=trust))
    with pytest.raises(ProtocolError) as exc:
        _decide(shield)
    text = str(exc.value)
    assert "Planner.decide() returned planned_wheels_mps of shape " + str(shape) in text and "(12, 2)" in text
    assert "horizon" in text and "\n" not in text


def test_a_plan_of_the_horizon_the_class_says_is_checked():
    d = _decide(Shield(Planner((6, 2), horizon=6), settings=CheckSettings(trust_plans=True)))
    assert (d.v_right_mps, d.v_left_mps) == (0.4, 0.4)
    d = _decide(Shield(Planner((12, 2)), settings=CheckSettings(trust_plans=True)))
    assert (d.v_right_mps, d.v_left_mps) == (0.4, 0.4)


def test_the_plan_refusal_names_the_user_s_class_behind_the_command_line_s_guard():
    """--controller MODULE:CLASS --shield named the command line's wrapper
    (gpcnav.controllers.UserController.decide() returned ...), not the class the user wrote."""
    from gpcnav.controllers import UserController
    shield = Shield(UserController("tests:Planner", Planner((6, 2))), settings=CheckSettings(trust_plans=True))
    with pytest.raises(ProtocolError, match=r"^test_shield_plans\.Planner\.decide\(\) returned planned_wheels_mps"):
        _decide(shield)
