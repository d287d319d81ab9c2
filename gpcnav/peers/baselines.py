"""The two baselines that sit beside every result on recorded people, so that a reader can
tell what the recording forces from what a planner does:

- ``stand``: a robot that stands still where it starts (how often people walk into a robot
  that does nothing);
- ``blind``: a robot that drives its reference and ignores everyone (how often the reference
  alone runs into people).

Both answer the Policy protocol. ``blind`` steers towards where the reference point will be
one sample ahead, at the speed that gets it there, within the wheels' speed and acceleration
limits (a plain unicycle tracking law on the one robot model's wheel speeds).
"""
from __future__ import annotations

import math

from casadi_gpc.robot import RobotParams
from casadi_gpc.types import ControlDecision, Observation

__all__ = ["StandStill", "BlindTracker"]


class StandStill:
    """Wheels at rest, always."""

    sample_time_s = 0.5

    def __init__(self, robot: RobotParams | None = None):
        self.robot = robot or RobotParams()

    def reset(self) -> None:
        pass

    def decide(self, observation: Observation) -> ControlDecision:
        return ControlDecision(0.0, 0.0)


class BlindTracker:
    """Drives the reference, blind to every obstacle (see the module text)."""

    sample_time_s = 0.5
    LOOKAHEAD_SAMPLES = 2
    """The reference point it aims at is this many samples ahead (one sample overshoots the
    heading on a curve)."""

    def __init__(self, robot: RobotParams | None = None):
        self.robot = robot or RobotParams()

    def reset(self) -> None:
        pass

    def decide(self, observation: Observation) -> ControlDecision:
        r, T = observation.robot, self.sample_time_s
        tx, ty, _ = observation.reference.pose_at_time(observation.t_s + self.LOOKAHEAD_SAMPLES * T)
        dx, dy = tx - r.x_m, ty - r.y_m
        dist = math.hypot(dx, dy)
        err = math.atan2(math.sin(math.atan2(dy, dx) - r.heading_rad), math.cos(math.atan2(dy, dx) - r.heading_rad))
        v = min(dist / (self.LOOKAHEAD_SAMPLES * T), self.robot.max_wheel_speed_mps) * max(math.cos(err), 0.0)
        w = err / T
        half = 0.5 * self.robot.wheel_base_m
        vr, vl = v + half * w, v - half * w
        top = max(abs(vr), abs(vl), 1e-12)
        scale = min(1.0, self.robot.max_wheel_speed_mps / top)
        vr, vl = vr * scale, vl * scale
        dv = self.robot.max_step_change_mps(T)
        vr = min(max(vr, r.v_right_mps - dv), r.v_right_mps + dv)
        vl = min(max(vl, r.v_left_mps - dv), r.v_left_mps + dv)
        return ControlDecision(vr, vl)
