"""A one-command network's own plan: the network rolled forward over the horizon against
the obstacles' forecasts (numpy only).

A check layer judges a bare command by what can follow it: braking, or the planner's
manoeuvres. Among walkers that do not see the robot, braking is often no way out, so the
check steps in even where the network would have gone on safely. The network's own
continuation is what it would do next: from the robot's predicted state, against the
obstacles where their forecasts put them, step after step. This is the paper's first pass
(the network rolled forward on its own predictions) with the obstacles in it; the check then
judges the roll-out as it judges a planner's plan (:meth:`casadi_gpc.safety.SafetyFilter.filter`,
``plan_on_demand``).

The features at step j are :func:`~nn_export.runtime.features.feature_values_from`'s for
the robot's predicted state and the desired poses from step j on, with each track seen where
its forecast has it after j steps (heading advanced by j turn increments, speed and turn as
estimated now, the uncertainty feature as now). The wheel speeds are held to the robot's
limits step by step, as the robot would.
"""
from __future__ import annotations

import numpy as np

from casadi_gpc.robot import RobotParams, RobotState, followed_wheel, robot_step_float

from .features import _window_tails, feature_values_from
from .layouts import FeatureLayout
from .set_slots import CrowdSlots

__all__ = ["roll_out"]


class _Ahead:
    """A track estimate as the features read it, ``j`` steps ahead on its forecast."""

    __slots__ = ("obstacle_id", "radius_m", "initialised", "state_values", "means_m", "covs_m2", "cov", "batch_",
                 "batch_index_")

    def __init__(self, track, xy, j: int):
        x, y, v, th, dth = track.state_values
        self.obstacle_id, self.radius_m, self.initialised = track.obstacle_id, track.radius_m, track.initialised
        self.state_values = (xy[0], xy[1], v, th + j * dth, dth)
        self.means_m = track.means_m[j - 1:]          # where it goes from then on (a sort reads it)
        self.covs_m2, self.cov = track.covs_m2, track.cov
        # a crowd's forecast rows: the uncertainty features read them together (the same numbers)
        self.batch_, self.batch_index_ = getattr(track, "batch_", None), getattr(track, "batch_index_", 0)


def roll_out(layout: FeatureLayout, answer, robot: RobotState, command: tuple[float, float], tracks, statics,
             reference_rows: list, sample_time_s: float, params: RobotParams, wall_rows=None,
             slots: CrowdSlots | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The plan ``(H, 2)`` whose first step is ``command`` and whose step j is the network's
    answer (``answer(values) -> (v_right, v_left)``) at step j, and the robot's poses after
    each step ``(H, 3)``. ``reference_rows``: the desired poses at steps 0..2H-1 (rows
    ``(x, y, heading)``); ``tracks``: the decision's track estimates (their forecasts cover
    the H steps); ``wall_rows``: the map's wall segments, for a layout that reads walls (the
    scan from each predicted pose). ``slots``: the decision's
    :class:`~nn_export.runtime.set_slots.CrowdSlots` of these tracks and statics, when it has
    them (a ``set`` layout, with or without its wall scan): the features of each step from its compiled slots (the
    same values), the reference windows' tails made once."""
    H, T = layout.horizon, float(sample_time_s)
    if len(reference_rows) < 2 * H:
        raise ValueError(f"a roll-out needs the desired poses at steps 0..{2 * H - 1}, got {len(reference_rows)}")
    W, vmax, dv = params.wheel_base_m, params.max_wheel_speed_mps, params.max_step_change_mps(T)
    vr, vl = float(command[0]), float(command[1])
    x, y, th = robot_step_float(float(robot.x_m), float(robot.y_m), float(robot.heading_rad), vr, vl, T, W)
    wheels, poses = [(vr, vl)], [(x, y, th)]
    if slots is not None:
        windows = _window_tails(layout, reference_rows[:2 * H], T)
        for j in range(1, H):
            nr, nl = answer(slots.values(x, y, th, vr, vl, reference_rows[j:j + H + 1], T, None, j, windows[j]))
            vr, vl = followed_wheel(vr, nr, dv, vmax), followed_wheel(vl, nl, dv, vmax)  # as the robot follows it
            x, y, th = robot_step_float(x, y, th, vr, vl, T, W)
            wheels.append((vr, vl))
            poses.append((x, y, th))
        return np.array(wheels), np.array(poses)
    paths = [(t, t.means_m.tolist()) for t in tracks]
    for j in range(1, H):
        ahead = [_Ahead(t, m[j - 1], j) for t, m in paths]
        nr, nl = answer(feature_values_from(layout, RobotState(x, y, th, vr, vl), reference_rows[j:j + H + 1], T,
                                            ahead, statics, None, wall_rows))
        vr, vl = followed_wheel(vr, nr, dv, vmax), followed_wheel(vl, nl, dv, vmax)  # as the robot follows it
        x, y, th = robot_step_float(x, y, th, vr, vl, T, W)
        wheels.append((vr, vl))
        poses.append((x, y, th))
    return np.array(wheels), np.array(poses)
