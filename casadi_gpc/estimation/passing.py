"""People who aim to pass the robot (:attr:`casadi_gpc.config.PlannerConfig.passing_samples`;
an option, off in both presets).

A tracked person whose straight-line forecast, against the robot carried on at its present
velocity, comes closer within :data:`LOOK_S` than it is now (by more than
:data:`CLOSING_M`) and yet stays outside contact (the robot's radius and the person's) by
less than :data:`BAND_M` aims to pass the robot. After a number of such samples in a row,
the person's forecast stops growing uncertain over the horizon: every step's covariance is
the first step's. The planner and its check read the same forecasts, so they agree.

Why (docs/pedestrians.md, "Who gives way, seen from the robot"): people who see the robot aim
to pass it 0.05 to 0.2 m outside contact, inside the margin that the forecast's growing
deviation adds; the planner backs away from them and is pushed back.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..types import ObstacleForecast, RobotState

__all__ = ["PassingEvidence", "LOOK_S", "CLOSING_M", "BAND_M"]

LOOK_S = 4.0
"""How far ahead a closest approach counts (s)."""
CLOSING_M = 0.05
"""By how much the closest approach must be nearer than now."""
BAND_M = 0.5
"""How far outside contact a closest approach may be and still be aimed at the robot."""


def aims_to_pass(robot: RobotState, robot_radius_m: float, f: ObstacleForecast, sample_time_s: float) -> bool:
    """Whether the forecast ``f`` (steps 1..H) closes on the robot, carried on straight at its
    present velocity, and passes it outside contact by less than :data:`BAND_M`."""
    means = np.asarray(f.means_m, dtype=float)
    k_max = min(len(means), int(round(LOOK_S / sample_time_s)))
    if k_max < 2:
        return False
    v = 0.5 * (robot.v_right_mps + robot.v_left_mps)
    k = np.arange(1, k_max + 1) * sample_time_s
    rx = robot.x_m + v * math.cos(robot.heading_rad) * k
    ry = robot.y_m + v * math.sin(robot.heading_rad) * k
    d = np.hypot(means[:k_max, 0] - rx, means[:k_max, 1] - ry)
    contact = robot_radius_m + f.radius_m
    closest = float(d.min())
    return bool(closest < d[0] - CLOSING_M and contact <= closest < contact + BAND_M)


class PassingEvidence:
    """Counts, per obstacle id, the samples in a row in which a person aimed to pass, and
    holds the forecasts of those with ``samples`` or more at their first step's uncertainty."""

    def __init__(self, samples: int, robot_radius_m: float, sample_time_s: float, counters: dict):
        self.samples = int(samples)
        self.robot_radius_m = float(robot_radius_m)
        self.sample_time_s = float(sample_time_s)
        self.counters = counters
        self.counters.setdefault("passing_tracks", 0)
        self._row: dict[int, int] = {}

    def reset(self) -> None:
        self._row.clear()

    def apply(self, robot: RobotState, forecasts: list[ObstacleForecast]) -> list[ObstacleForecast]:
        """``forecasts`` with those of people who have aimed to pass for ``samples`` samples in a
        row held at their first step's covariance (the others as given)."""
        row, out = {}, []
        for f in forecasts:
            n = self._row.get(f.obstacle_id, 0) + 1 if aims_to_pass(robot, self.robot_radius_m, f,
                                                                      self.sample_time_s) else 0
            if n:
                row[f.obstacle_id] = n
            if n >= self.samples:
                covs = np.asarray(f.covs_m2, dtype=float)
                f = replace(f, covs_m2=np.broadcast_to(covs[:1], covs.shape).copy())
                self.counters["passing_tracks"] += 1
            out.append(f)
        self._row = row
        return out
