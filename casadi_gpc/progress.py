"""Where the reference point is: the paper's clock, or a clock that waits for the robot."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .reference import ReferencePath
from .types import samples_since

__all__ = ["ReferenceClock"]


@dataclass
class ReferenceClock:
    """Arc length of the reference point, advanced once per sample.

    With ``max_lead_m`` None this is the paper's reference, ``s = speed * t``. Otherwise the
    point moves at the reference speed but never more than ``max_lead_m`` ahead of the
    robot's projection on the path, so a robot that yields to an obstacle is not left
    chasing a point that ran away (and it never moves backwards).

    Waiting must not become a deadlock (a gap too narrow to pass is a local minimum where
    a robot held on a short leash would wait forever): after ``patience_s`` without
    progress along the path, the allowed lead grows at the reference speed, so the pull
    of the reference grows as it does under the paper's clock until going around is
    cheaper than waiting. Progress shrinks the lead back at the same rate.
    """

    sample_time_s: float
    max_lead_m: float | None = None
    patience_s: float = 5.0
    s_m: float = 0.0
    _proj_m: float = 0.0
    _stalled_s: float = 0.0
    _extra_lead_m: float = 0.0
    _started: bool = False
    _last_t_s: float | None = None

    def reset(self) -> None:
        self.s_m = 0.0
        self._proj_m = 0.0
        self._stalled_s = 0.0
        self._extra_lead_m = 0.0
        self._started = False
        self._last_t_s = None

    def update(self, path: ReferencePath, t_s: float, robot_xy) -> float:
        """The reference arc length for the sample at ``t_s`` (call once per sample; a sample k > 1
        samples after the last one's, :func:`~casadi_gpc.types.samples_since`, advances the point and
        the patience's count by k samples, the observations between having been missed)."""
        k = samples_since(self._last_t_s, t_s, self.sample_time_s)  # raises before anything changes
        self._last_t_s = t_s
        # path.arclength_at_time on a plain float (np.clip costs more than the rest of the update);
        # min(max(., 0), L) written out (the same numbers, -0.0 and nan included)
        nominal = path.speed_mps * float(t_s)
        if nominal < 0.0:
            nominal = 0.0
        elif nominal > path.length_m:
            nominal = path.length_m
        if self.max_lead_m is None:
            self.s_m = nominal
            return self.s_m
        if not self._started:
            self._started = True
            if t_s > 0.0:
                return self._join(path, nominal, robot_xy)
        previous = self._proj_m
        self._proj_m = path.project(robot_xy, self._proj_m, window_m=1.0)
        if t_s <= 0.0:
            self.s_m = 0.0
            return self.s_m
        step = path.speed_mps * self.sample_time_s * k
        if self._proj_m - previous < 0.25 * step and self.s_m < nominal:
            self._stalled_s += self.sample_time_s * k
        else:
            self._stalled_s = 0.0
        if self._stalled_s > self.patience_s:
            self._extra_lead_m += step
        else:
            self._extra_lead_m = max(0.0, self._extra_lead_m - step)
        lead = self.max_lead_m + self._extra_lead_m
        self.s_m = min(self.s_m + step, max(self.s_m, self._proj_m + lead), nominal)
        return self.s_m

    def _join(self, path: ReferencePath, nominal: float, robot_xy) -> float:
        """The first sample after a reset comes at ``t_s`` > 0 (a robot's own clock, a
        controller started part-way): the robot's projection is searched along the whole path
        the paper's point has covered (to 2 cm, then refined), and the point put ``max_lead_m``
        ahead of it, no further than the paper's. It started at the path's start and searched
        within 1 m of it: a robot at the path's end at t = 31 s reversed away from its goal, and
        one on schedule 6 m along stopped."""
        half = 0.5 * nominal
        coarse = path.project(robot_xy, half, window_m=half, samples=max(81, int(nominal / 0.02) + 1))
        self._proj_m = path.project(robot_xy, coarse, window_m=0.05)
        self.s_m = min(self._proj_m + self.max_lead_m, nominal)
        return self.s_m

    def horizon_arclengths(self, path: ReferencePath, horizon: int) -> np.ndarray:
        """Arc lengths of the desired points at steps 1..H."""
        step = path.speed_mps * self.sample_time_s
        return np.clip(self.s_m + step * np.arange(1, horizon + 1), 0.0, path.length_m)
