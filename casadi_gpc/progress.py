"""Where the reference point is: the paper's clock, or a clock that waits for the robot."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .reference import ReferencePath

__all__ = ["ReferenceClock"]


@dataclass
class ReferenceClock:
    """Arc length of the reference point, advanced once per sample.

    With ``max_lead_m`` None this is the paper's reference, ``s = speed * t``. Otherwise the
    point moves at the reference speed but never more than ``max_lead_m`` ahead of the
    robot's projection on the path, so a robot that yields to an obstacle is not left
    chasing a point that ran away (and it never moves backwards).
    """

    sample_time_s: float
    max_lead_m: float | None = None
    s_m: float = 0.0
    _proj_m: float = 0.0

    def reset(self) -> None:
        self.s_m = 0.0
        self._proj_m = 0.0

    def update(self, path: ReferencePath, t_s: float, robot_xy) -> float:
        """The reference arc length for the sample at ``t_s`` (call once per sample)."""
        if self.max_lead_m is None:
            self.s_m = float(path.arclength_at_time(t_s))
            return self.s_m
        self._proj_m = path.project(robot_xy, self._proj_m, window_m=1.0)
        nominal = float(path.arclength_at_time(t_s))
        if t_s <= 0.0:
            self.s_m = 0.0
        else:
            step = path.speed_mps * self.sample_time_s
            self.s_m = min(self.s_m + step, max(self.s_m, self._proj_m + self.max_lead_m), nominal)
        return self.s_m

    def horizon_arclengths(self, path: ReferencePath, horizon: int) -> np.ndarray:
        """Arc lengths of the desired points at steps 1..H."""
        step = path.speed_mps * self.sample_time_s
        return np.clip(self.s_m + step * np.arange(1, horizon + 1), 0.0, path.length_m)
