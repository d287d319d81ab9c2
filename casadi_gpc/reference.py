"""Reference trajectories: a path of line and arc pieces traversed at a set speed.

The desired pose at time t is the point at arc length ``min(speed * t, length)``.
Numpy only, so the deployed policy can use it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .robot import arc_step

__all__ = ["Segment", "ReferencePath"]


@dataclass(frozen=True)
class Segment:
    """A piece of constant curvature: a line (``curvature_1pm`` 0) or an arc."""

    length_m: float
    curvature_1pm: float = 0.0

    @staticmethod
    def line(length_m: float) -> "Segment":
        return Segment(float(length_m), 0.0)

    @staticmethod
    def arc(radius_m: float, angle_rad: float) -> "Segment":
        """An arc; a positive angle turns left."""
        return Segment(float(radius_m * abs(angle_rad)), float(np.sign(angle_rad) / radius_m))


@dataclass(frozen=True)
class ReferencePath:
    """A desired space-time trajectory (CONTRACT: ``[reference]``)."""

    start_xy_m: tuple[float, float]
    start_heading_rad: float
    segments: tuple[Segment, ...]
    speed_mps: float

    def __post_init__(self):
        if not self.segments:
            raise ValueError("reference path has no segments")
        x, y, h = float(self.start_xy_m[0]), float(self.start_xy_m[1]), float(self.start_heading_rad)
        starts, cum = [], [0.0]
        for seg in self.segments:
            starts.append((x, y, h))
            x, y, h = (float(v) for v in arc_step(np, x, y, h, 1.0, seg.curvature_1pm, seg.length_m))
            cum.append(cum[-1] + seg.length_m)
        object.__setattr__(self, "_starts", np.array(starts))
        object.__setattr__(self, "_cum", np.array(cum))
        object.__setattr__(self, "_curv", np.array([s.curvature_1pm for s in self.segments]))

    @property
    def length_m(self) -> float:
        return float(self._cum[-1])

    @property
    def duration_s(self) -> float:
        """Time the reference point needs to reach the end of the path."""
        return self.length_m / self.speed_mps

    @property
    def end_pose(self) -> np.ndarray:
        return self.pose_at_arclength(self.length_m)

    def _segment_index(self, s):
        return np.clip(np.searchsorted(self._cum, s, side="right") - 1, 0, len(self.segments) - 1)

    def pose_at_arclength(self, s) -> np.ndarray:
        """Pose ``[x, y, heading]`` (shape ``(..., 3)``) at arc length ``s``, clipped to the path."""
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length_m)
        i = self._segment_index(s)
        x0, y0, h0 = self._starts[i].T if np.ndim(s) else self._starts[i]
        x, y, h = arc_step(np, x0, y0, h0, 1.0, self._curv[i], s - self._cum[i])
        return np.stack([x, y, h], axis=-1)

    def curvature_at_arclength(self, s) -> np.ndarray:
        s = np.clip(np.asarray(s, dtype=float), 0.0, self.length_m)
        return self._curv[self._segment_index(s)]

    def arclength_at_time(self, t_s) -> np.ndarray:
        return np.clip(self.speed_mps * np.asarray(t_s, dtype=float), 0.0, self.length_m)

    def pose_at_time(self, t_s) -> np.ndarray:
        return self.pose_at_arclength(self.arclength_at_time(t_s))

    def project(self, xy, s_guess: float, window_m: float = 2.0, samples: int = 81) -> float:
        """Arc length of the path point nearest ``xy``, searched near ``s_guess``."""
        s = np.linspace(s_guess - window_m, s_guess + window_m, samples)
        s = np.clip(s, 0.0, self.length_m)
        p = self.pose_at_arclength(s)
        d2 = (p[:, 0] - xy[0]) ** 2 + (p[:, 1] - xy[1]) ** 2
        return float(s[int(np.argmin(d2))])

    def polyline(self, step_m: float = 0.05) -> np.ndarray:
        n = max(2, int(np.ceil(self.length_m / step_m)) + 1)
        return self.pose_at_arclength(np.linspace(0.0, self.length_m, n))
