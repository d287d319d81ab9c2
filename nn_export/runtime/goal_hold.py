"""The deployed policy at the end of its reference (numpy only).

Where the reference has ended, the network's answer is a stop up to its own error: 0.05 m from
Fig. 7.2's end the shipped network commanded 0.05 m/s, then 0.02 m/s on both wheels for ever, and a
robot driving it crept 0.74 m past its goal in 20 s (the GPC holds still there; measured 2026-12-01).
Within :data:`GOAL_HOLD_M` of a finished reference's end the reference asks nothing more: the policy
commands standing still (:func:`goal_hold`; counted ``goal_holds``), a decision the check layer judges
as any other (a person coming at the robot standing at its goal is the check's to answer). Further out,
within :data:`GOAL_REACHED_M` (the simulator's goal tolerance), it stands still where the network's
command would not take it nearer the goal: past its goal, beside it or facing back at it, the network
crept away (0.15 m past Fig. 7.2's end: 0.77 m from it 20 s later; measured 2026-12-01)."""
from __future__ import annotations

import math

import numpy as np

from casadi_gpc.types import ControlDecision

__all__ = ["GOAL_HOLD_M", "GOAL_REACHED_M", "goal_hold"]

GOAL_HOLD_M = 0.1
"""How near the end of a finished reference the robot is held (m): a third of the simulator's goal
tolerance (0.3 m, ``scenarios.simulator.GOAL_TOLERANCE_M``), so a simulated episode has ended,
reached, before any hold (its outcomes are the same with or without it)."""

GOAL_REACHED_M = 0.3
"""Within this distance of a finished reference's end the robot has reached its goal (the
simulator's ``GOAL_TOLERANCE_M``, the same number: a test keeps them equal), and a command that
does not take it nearer is held too (a simulated episode has ended there as well)."""


def goal_hold(decision: ControlDecision, observation, reference_s_m: float, horizon: int) -> ControlDecision | None:
    """A decision to stand still in place of ``decision`` when the reference point has reached the
    end of the path (``reference_s_m``, the policy's reference clock) and the robot is within
    :data:`GOAL_HOLD_M` of it, or within :data:`GOAL_REACHED_M` of it with a command whose mean
    speed does not take it towards it; else None. Its plan: standing for the ``horizon``, where
    the robot is."""
    ref = observation.reference
    if reference_s_m < ref.length_m:
        return None
    r = observation.robot
    end = ref.end_pose
    dx, dy = float(end[0]) - r.x_m, float(end[1]) - r.y_m
    d = math.hypot(dx, dy)
    if d > GOAL_REACHED_M:
        return None
    if d > GOAL_HOLD_M:
        v = 0.5 * (decision.v_right_mps + decision.v_left_mps)
        if v * (dx * math.cos(r.heading_rad) + dy * math.sin(r.heading_rad)) > 0.0:  # on its way to the goal
            return None
    poses = np.tile([float(r.x_m), float(r.y_m), float(r.heading_rad)], (horizon, 1))
    return ControlDecision(0.0, 0.0, False, "goal hold: the reference has ended", np.zeros((horizon, 2)), poses,
                           info=decision.info, forecasts=decision.forecasts)
