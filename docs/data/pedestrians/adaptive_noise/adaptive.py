"""Experiment (not shipped): the obstacle filter's speed and heading process noise adapted per
track to its own innovations (covariance matching). Each accepted update's normalised
innovation squared (NIS, chi-square with 2 dof when the model fits: mean 2) is kept over the
last WINDOW updates; the track's speed and heading noise variances are the shipped ones times
alpha multiplied at each update by mean NIS / 2 (at least 1), their standard deviations capped at people's (0.3 m/s^2,
0.05 rad: tools/forecast_bound.py's PEOPLE_NOISE, the recorded positions within 2 sigma 87-95 %
of the time). install() patches ObstacleEKF (its batched update is bypassed: each filter steps
on its own, which is the same arithmetic)."""
import math
from collections import deque
from dataclasses import replace

from casadi_gpc.estimation import ekf as E

WINDOW = 6                      # 3 s of updates at the planner's 0.5 s
CAP = {"speed_noise_mps2": 0.3, "heading_noise_rad": 0.05}


def _nis(f, zx, zy):
    c = f._consts
    if c[0] is not f.settings or c[1] != f.sample_time_s:
        c = f._constants()
    x, y, v, th, dth = f._s
    x, y, th, U = E._propagate(x, y, v, th, dth, f._U, c[1], c[2], 1)
    a, b, d = U[0] + c[3], U[1], U[5] + c[3]
    det = a * d - b * b
    i0, i1 = zx - x, zy - y
    return (d * i0 * i0 - 2 * b * i0 * i1 + a * i1 * i1) / det


def install():
    orig_step = E.ObstacleEKF.step

    def step(self, z):
        base = self.__dict__.get("_adapt_base")
        if base is None:
            base = self._adapt_base = self.settings
            self._adapt_nis = deque(maxlen=WINDOW)
        nis = None
        if z is not None and self._s is not None and self.measurements_seen_ >= 2:
            zx, zy = float(z[0]), float(z[1])
            if math.isfinite(zx) and math.isfinite(zy):
                nis = _nis(self, zx, zy)
        out = orig_step(self, z)
        if out == "update" and nis is not None:
            self._adapt_nis.append(nis)
        elif out == "start":
            self._adapt_nis.clear()
        if out == "update" and nis is not None:
            # covariance matching: the noise scaled until the innovations are as large as the
            # filter expects (mean NIS 2), never below the shipped noise
            self._adapt_alpha = min(max(1.0, self.__dict__.get("_adapt_alpha", 1.0) * (sum(self._adapt_nis) / len(self._adapt_nis) / 2.0)), 1e4)
        elif out == "start":
            self._adapt_alpha = 1.0
        alpha = self.__dict__.get("_adapt_alpha", 1.0)
        if alpha > 1.0:
            s = math.sqrt(alpha)
            self.settings = replace(base, speed_noise_mps2=min(base.speed_noise_mps2 * s, CAP["speed_noise_mps2"]),
                                    heading_noise_rad=min(base.heading_noise_rad * s, CAP["heading_noise_rad"]))
        else:
            self.settings = base
        return out

    E.ObstacleEKF.step = step
    E.ObstacleEKF.update_together = staticmethod(lambda filters, zs: [False] * len(filters))
