"""The one rule for "a number" in the arguments and settings checked across gpcnav (numbers only:
every module may import it)."""
from __future__ import annotations

import math
from numbers import Real

__all__ = ["finite_real"]


def finite_real(value) -> bool:
    """Whether ``value`` is a number: a real one (numpy's too; not a bool, not a string that
    reads as one) and finite. The rule behind every numeric argument and setting checked
    (:class:`~casadi_gpc.robot.RobotParams`, :class:`~casadi_gpc.estimation.ekf.EKFSettings`, the
    check's settings, the sample times, the deployed policy's, the Gymnasium rewards')."""
    return isinstance(value, Real) and not isinstance(value, bool) and math.isfinite(value)
