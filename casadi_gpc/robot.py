"""The differential-drive robot: parameters, state and the paper's exact-arc model.

The motion over one interval with constant wheel speeds is written once, in
:func:`arc_step`, against a math module ``xp`` (``numpy`` or ``casadi``), so the NLP,
the simulator, the obstacle EKF and the deployed policy share one definition.

The paper writes the step as ``x + V/A (sin(theta + A T) - sin(theta))``, which divides
by zero when the wheels turn at the same speed. The identical half-angle form
``x + V T sinc(A T / 2) cos(theta + A T / 2)`` is used instead, with a sinc that is a
Taylor polynomial near zero, so the model is exact, finite and smooth everywhere.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .finite import finite_real

__all__ = [
    "RobotParams",
    "RobotState",
    "sinc",
    "arc_step",
    "robot_step",
    "robot_step_float",
    "wheel_to_unicycle",
    "brake_wheels",
    "followed_wheel",
    "followed_plan",
]

_SINC_SWITCH = 1e-3  # below this |u| the Taylor series is exact to ~1e-22


@dataclass(frozen=True)
class RobotParams:
    """Geometry and limits of a Labmate-class differential-drive robot (CONTRACT defaults)."""

    wheel_base_m: float = 0.5
    """Distance W between the two driving wheels."""
    radius_m: float = 0.35
    """Radius of the disc that bounds the robot, used for clearances."""
    max_wheel_speed_mps: float = 0.8
    """Each wheel's speed limit, both directions."""
    max_wheel_accel_mps2: float = 0.8
    """Each wheel's acceleration limit: at most this times T change per step."""

    def __post_init__(self):
        # (a radius of -1 or a NaN wheel base was taken: a policy then blamed "another robot", a planner
        # divided by it; the scenario files' rule: every one a positive number)
        for name in ("wheel_base_m", "radius_m", "max_wheel_speed_mps", "max_wheel_accel_mps2"):
            v = getattr(self, name)
            if not (finite_real(v) and v > 0):
                raise ValueError(f"RobotParams.{name} must be a positive number, got {v!r}")

    def max_step_change_mps(self, sample_time_s: float) -> float:
        """Largest change of one wheel's speed in one sample interval."""
        return self.max_wheel_accel_mps2 * sample_time_s

    def to_dict(self) -> dict:
        return {
            "wheel_base_m": self.wheel_base_m,
            "radius_m": self.radius_m,
            "max_wheel_speed_mps": self.max_wheel_speed_mps,
            "max_wheel_accel_mps2": self.max_wheel_accel_mps2,
        }


@dataclass(frozen=True)
class RobotState:
    """Pose of the robot and the wheel speeds applied over the last interval."""

    x_m: float
    y_m: float
    heading_rad: float
    v_right_mps: float = 0.0
    v_left_mps: float = 0.0

    def as_array(self) -> np.ndarray:
        return np.array([self.x_m, self.y_m, self.heading_rad, self.v_right_mps, self.v_left_mps])


def sinc(xp, u):
    """sin(u)/u, exact and smooth through u = 0, for ``xp`` = numpy, casadi or math (plain
    floats: the deployed policy's roll-out, where numpy's per-call cost dominates)."""
    if xp is math:  # one branch evaluated: the same numbers as below, at half the cost
        if math.fabs(u) < _SINC_SWITCH:
            u2 = u * u
            return 1.0 - u2 / 6.0 + u2 * u2 / 120.0
        return math.sin(u) / u
    small = xp.fabs(u) < _SINC_SWITCH
    u2 = u * u
    taylor = 1.0 - u2 / 6.0 + u2 * u2 / 120.0
    if xp is np:
        safe_u = np.where(small, 1.0, u)
        return np.where(small, taylor, np.sin(safe_u) / safe_u)
    safe_u = xp.if_else(small, 1.0, u)
    return xp.if_else(small, taylor, xp.sin(safe_u) / safe_u)


def arc_step(xp, x, y, heading, speed, turn_rate, dt):
    """Exact motion at constant speed (m/s) and turn rate (rad/s) for ``dt`` seconds.

    Works element-wise on numpy arrays and on casadi expressions. Returns the new
    ``(x, y, heading)``.
    """
    half = 0.5 * turn_rate * dt
    chord = speed * dt * sinc(xp, half)
    mid = heading + half
    return x + chord * xp.cos(mid), y + chord * xp.sin(mid), heading + 2.0 * half


def wheel_to_unicycle(v_right, v_left, wheel_base_m):
    """Wheel speeds to (forward speed V, turn rate A) as in the paper."""
    return 0.5 * (v_right + v_left), (v_right - v_left) / wheel_base_m


def robot_step(xp, x, y, heading, v_right, v_left, dt, wheel_base_m):
    """The paper's robot model: constant wheel speeds over ``dt`` seconds."""
    speed, turn_rate = wheel_to_unicycle(v_right, v_left, wheel_base_m)
    return arc_step(xp, x, y, heading, speed, turn_rate, dt)


def robot_step_float(x: float, y: float, heading: float, v_right: float, v_left: float, dt: float,
                     wheel_base_m: float) -> tuple[float, float, float]:
    """``robot_step(math, ...)`` in one call, for plain floats: the same operations in the
    same order, so the same numbers bit for bit (tested). For the step loops of the
    deployed policy and its safety filter, where the general form's four nested calls
    cost more than the arithmetic."""
    speed, turn_rate = 0.5 * (v_right + v_left), (v_right - v_left) / wheel_base_m  # wheel_to_unicycle
    half = 0.5 * turn_rate * dt  # arc_step
    if -_SINC_SWITCH < half < _SINC_SWITCH:  # sinc: fabs(half) < switch (False for NaN either way)
        u2 = half * half
        chord = speed * dt * (1.0 - u2 / 6.0 + u2 * u2 / 120.0)
    else:
        chord = speed * dt * (math.sin(half) / half)
    mid = heading + half
    return x + chord * math.cos(mid), y + chord * math.sin(mid), heading + 2.0 * half


robot_step_compiled = njit(cache=True)(robot_step_float)
"""The robot model's float form compiled (numba), for compiled loops (the check's roll-outs, the
planner's test of a guess against the walls): the same operations, so the same numbers."""


def followed_wheel(v_now: float, v_asked: float, dv_max: float, v_max: float) -> float:
    """The speed one wheel reaches when asked for ``v_asked`` from ``v_now``: the rate limit
    first, then the speed limit (the simulator's clipping, on plain floats)."""
    return min(max(min(max(v_asked, v_now - dv_max), v_now + dv_max), -v_max), v_max)


def followed_plan(v_right: float, v_left: float, wheels, dv_max: float, v_max: float) -> np.ndarray:
    """The (H, 2) wheel speeds the robot reaches when asked for the plan ``wheels`` (H, 2) from its
    wheels' speeds now: :func:`followed_wheel` step by step (the simulator's clipping). A plan
    within the limits comes back as it is, number for number."""
    vr, vl, rows = float(v_right), float(v_left), []
    for r, l in np.asarray(wheels, dtype=float).tolist():
        vr, vl = followed_wheel(vr, r, dv_max, v_max), followed_wheel(vl, l, dv_max, v_max)
        rows.append((vr, vl))
    return np.array(rows).reshape(-1, 2)


def brake_wheels(v_right: float, v_left: float, dv_max: float) -> tuple[float, float]:
    """Both wheels one step towards zero within the acceleration limit ``dv_max`` (m/s)."""
    def toward_zero(v):
        return float(np.sign(v) * max(abs(v) - dv_max, 0.0))
    return toward_zero(v_right), toward_zero(v_left)
