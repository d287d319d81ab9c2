"""A user's class behind the check layer, its numbers numpy's: a sample time read from a config
array (``np.float32(0.5)``) is a positive number of seconds, and a horizon of ``np.int64(8)`` is
the controller's own. The layer refused the first ("must be a positive number, got
np.float32(0.5)"), as did ``--controller MODULE:CLASS``, and ignored the second in silence,
checking 12 samples (6 s) instead of the controller's 8."""
from __future__ import annotations

import numpy as np
import pytest

from casadi_gpc import ControlDecision, Observation, ReferencePath, RobotState, Segment
from casadi_gpc.safety import Shield


class NumpyPolicy:
    def __init__(self, T=np.float32(0.5), horizon=None):
        self.sample_time_s = T
        if horizon is not None:
            self.horizon = horizon

    def reset(self) -> None:
        pass

    def decide(self, observation) -> ControlDecision:
        return ControlDecision(0.3, 0.3)


@pytest.mark.parametrize("T", [np.float32(0.5), np.float64(0.5), np.int64(1), 0.5])
def test_a_numpy_sample_time_is_a_sample_time(T):
    shield = Shield(NumpyPolicy(T))
    assert shield.sample_time_s == float(T) and type(shield.sample_time_s) is float
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(10.0),), 0.4)
    d = shield.decide(Observation(0.0, RobotState(0.0, 0.0, 0.0), ref))
    assert (d.v_right_mps, d.v_left_mps) == (0.3, 0.3)


@pytest.mark.parametrize("T", [np.float32(0.0), np.float64(np.nan), True, "0.5", np.array([0.5])])
def test_a_sample_time_that_is_not_a_positive_number_is_still_refused(T):
    with pytest.raises(TypeError, match="sample_time_s must be a positive number"):
        Shield(NumpyPolicy(T))


def test_a_numpy_horizon_is_the_controllers_own():
    assert Shield(NumpyPolicy(0.5, np.int64(8))).horizon == 8
    assert Shield(NumpyPolicy(0.5, 8)).horizon == 8
    assert Shield(NumpyPolicy(0.5)).horizon == 12  # none: 6 s of its samples


def test_the_command_line_takes_a_numpy_sample_time():
    from gpcnav.user_controllers import _check_protocol
    from gpcnav.errors import UsageError
    _check_protocol("mymod:NumpyPolicy", NumpyPolicy(np.float32(0.5)))
    with pytest.raises(UsageError, match="sample_time_s must be a positive number"):
        _check_protocol("mymod:NumpyPolicy", NumpyPolicy(np.float32(-0.5)))
