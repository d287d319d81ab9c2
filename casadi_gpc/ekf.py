"""Extended Kalman filter for one moving obstacle (the paper's section 3).

State ``s = [x, y, V, theta, dtheta]``: position (m), speed (m/s), heading of the last
displacement (rad) and its change per sample (rad/step). Model (constant speed,
constant turn increment), with T the sample time::

    theta' = theta + dtheta
    x'     = x + V T cos(theta')
    y'     = y + V T sin(theta')
    V' = V,  dtheta' = dtheta

Measurements are positions with white noise. Numpy only (the deployed policy uses it).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["EKFSettings", "ObstacleEKF", "obstacle_model_step", "GATE_CHI2_2DOF"]

GATE_CHI2_2DOF = 18.42  # chi-square(2) 0.9999 quantile: an innovation beyond it is an outlier


def obstacle_model_step(s: np.ndarray, sample_time_s: float) -> np.ndarray:
    """One step of the paper's obstacle model on an array of states (last axis of size 5)."""
    x, y, v, th, dth = np.moveaxis(np.asarray(s, dtype=float), -1, 0)
    th1 = th + dth
    return np.stack(
        [x + v * sample_time_s * np.cos(th1), y + v * sample_time_s * np.sin(th1), v, th1, dth], axis=-1
    )


def _jacobian(s: np.ndarray, T: float) -> np.ndarray:
    _, _, v, th, dth = s
    th1 = th + dth
    c, si = np.cos(th1), np.sin(th1)
    F = np.eye(5)
    F[0, 2], F[0, 3], F[0, 4] = T * c, -v * T * si, -v * T * si
    F[1, 2], F[1, 3], F[1, 4] = T * si, v * T * c, v * T * c
    F[3, 4] = 1.0
    return F


@dataclass(frozen=True)
class EKFSettings:
    """Noise levels of the obstacle filter."""

    measurement_std_m: float = 0.02
    """Standard deviation of each measured coordinate (floored at 1 mm for conditioning)."""
    speed_noise_mps2: float = 0.05
    """Random-walk acceleration of the obstacle's speed: std of the change is this times T."""
    turn_noise_rad: float = 0.01
    """Std of the change of the turn increment per step."""
    heading_noise_rad: float = 0.005
    """Std of an unmodelled heading change per step."""
    position_noise_m: float = 0.002
    """Std of an unmodelled displacement per step."""
    initial_turn_std_rad: float = 0.1
    """Std of the turn increment when the track starts (nothing is known of it yet)."""
    initial_speed_std_mps: float = 1.0
    """Std of the speed while only one position has been seen."""
    gate_chi2: float = GATE_CHI2_2DOF
    """Mahalanobis gate of the innovation; larger innovations are rejected as outliers."""
    max_rejections: int = 3
    """After this many outliers in a row the track restarts at the new measurement."""


@dataclass
class ObstacleEKF:
    """Track of one moving obstacle. ``update`` once per sample, then ``predict``."""

    sample_time_s: float
    settings: EKFSettings = field(default_factory=EKFSettings)
    state_: np.ndarray | None = None
    cov_: np.ndarray | None = None
    measurements_seen_: int = 0
    missed_: int = 0
    outliers_: int = 0
    _last_z: np.ndarray | None = None
    _rejections_in_row: int = 0
    _steps_since_first: int = 1  # samples between the first and the second measurement

    def _R(self) -> np.ndarray:
        return np.eye(2) * max(self.settings.measurement_std_m, 1e-3) ** 2

    def _Q(self) -> np.ndarray:
        st, T = self.settings, self.sample_time_s
        return np.diag([
            st.position_noise_m ** 2, st.position_noise_m ** 2,
            (st.speed_noise_mps2 * T) ** 2, st.heading_noise_rad ** 2, st.turn_noise_rad ** 2,
        ])

    @property
    def initialised(self) -> bool:
        return self.measurements_seen_ >= 2

    def _start(self, z: np.ndarray) -> None:
        st = self.settings
        self.state_ = np.array([z[0], z[1], 0.0, 0.0, 0.0])
        r = max(st.measurement_std_m, 1e-3) ** 2
        self.cov_ = np.diag([r, r, st.initial_speed_std_mps ** 2, np.pi ** 2, st.initial_turn_std_rad ** 2])
        self.measurements_seen_ = 1
        self._last_z = z
        self._rejections_in_row = 0
        self._steps_since_first = 1

    def _second(self, z: np.ndarray) -> None:
        """Two positions give speed and heading by finite difference."""
        st = self.settings
        T = self.sample_time_s * self._steps_since_first  # missed samples in between lengthen the baseline
        d = z - self._last_z
        v = float(np.hypot(*d)) / T
        r = max(st.measurement_std_m, 1e-3) ** 2
        var_v = 2.0 * r / T ** 2
        var_th = min(np.pi ** 2, 2.0 * r / max(v * T, 1e-6) ** 2)
        self.state_ = np.array([z[0], z[1], v, np.arctan2(d[1], d[0]), 0.0])
        self.cov_ = np.diag([r, r, var_v, var_th, st.initial_turn_std_rad ** 2])
        self.measurements_seen_ = 2

    def step(self, z) -> str:
        """Advance one sample and fuse measurement ``z`` (``None`` or non-finite = missing).

        Returns what happened: ``"start"``, ``"update"``, ``"missed"`` or ``"outlier"``.
        Raises ``ValueError`` when ``z`` is not a position (two numbers).
        """
        z = None if z is None else np.asarray(z, dtype=float)
        if z is not None and z.shape != (2,):
            raise ValueError(f"an obstacle measurement is a position (x, y), got shape {z.shape}")
        if z is not None and not np.all(np.isfinite(z)):
            z = None
        if self.state_ is None:
            if z is None:
                self.missed_ += 1
                return "missed"
            self._start(z)
            return "start"
        if self.measurements_seen_ == 1:
            if z is None:
                self.missed_ += 1
                self._steps_since_first += 1
                # a stationary guess whose uncertainty grows with the unknown speed
                self.cov_[:2, :2] += np.eye(2) * (self.settings.initial_speed_std_mps * self.sample_time_s) ** 2
                return "missed"
            self._second(z)
            self._last_z = z
            return "update"
        # propagation
        F = _jacobian(self.state_, self.sample_time_s)
        self.state_ = obstacle_model_step(self.state_, self.sample_time_s)
        self.cov_ = F @ self.cov_ @ F.T + self._Q()
        if z is None:
            self.missed_ += 1
            return "missed"
        # correction, with an innovation gate against outliers
        innov = z - self.state_[:2]
        S = self.cov_[:2, :2] + self._R()
        m2 = float(innov @ np.linalg.solve(S, innov))
        if m2 > self.settings.gate_chi2:
            self.outliers_ += 1
            self._rejections_in_row += 1
            if self._rejections_in_row >= self.settings.max_rejections:
                self._start(z)  # the obstacle really is somewhere else: start over
                return "start"
            return "outlier"
        self._rejections_in_row = 0
        K = self.cov_[:, :2] @ np.linalg.inv(S)
        self.state_ = self.state_ + K @ innov
        self.state_[3] = (self.state_[3] + np.pi) % (2 * np.pi) - np.pi
        IKH = np.eye(5) - K[:, :2] @ np.eye(2, 5)
        self.cov_ = IKH @ self.cov_ @ IKH.T + K @ self._R() @ K.T  # Joseph form
        self._last_z = z
        return "update"

    def predict(self, horizon: int) -> tuple[np.ndarray, np.ndarray]:
        """Predicted positions ``(H, 2)`` and their covariances ``(H, 2, 2)`` for steps 1..H."""
        if self.state_ is None:
            raise RuntimeError("predict() before any measurement")
        means = np.empty((horizon, 2))
        covs = np.empty((horizon, 2, 2))
        s, P = self.state_.copy(), self.cov_.copy()
        if self.measurements_seen_ == 1:
            grow = (self.settings.initial_speed_std_mps * self.sample_time_s) ** 2
            for j in range(horizon):
                means[j] = s[:2]
                covs[j] = P[:2, :2] + np.eye(2) * grow * (j + 1) ** 2
            return means, covs
        Q = self._Q()
        for j in range(horizon):
            F = _jacobian(s, self.sample_time_s)
            s = obstacle_model_step(s, self.sample_time_s)
            P = F @ P @ F.T + Q
            means[j] = s[:2]
            covs[j] = P[:2, :2]
        return means, covs
