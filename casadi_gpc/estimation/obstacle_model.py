"""The obstacle filter's model and its frozen estimate (the paper's section 3), apart from the
filter's step (:mod:`casadi_gpc.estimation.ekf`): the noise levels (:class:`EKFSettings`), the
model's step and Jacobian, the process noise, the straight forecast's start, the estimate frozen
at a sample (:class:`FilterState`) and its H-step forecast, and the covariances a planner reads
of it. Numpy only (the deployed policy uses it).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import NamedTuple

import numpy as np

from ..finite import finite_real
from .ekf_floats import cov_array as _cov_array, forecast as _forecast, straight_noise

__all__ = ["EKFSettings", "FilterState", "obstacle_model_step", "planning_covariances", "worst_std_m",
           "straightened", "standing_forecasts", "GATE_CHI2_2DOF"]

GATE_CHI2_2DOF = 18.42  # chi-square(2) 0.9999 quantile: an innovation beyond it is an outlier


def planning_covariances(covs_m2: np.ndarray, initialised: bool) -> np.ndarray:
    """The forecast covariances a planner uses. For a track seen once (speed and heading
    unknown, :attr:`ObstacleEKF.initialised <casadi_gpc.estimation.ekf.ObstacleEKF.initialised>` false) the filter predicts the obstacle standing
    with an uncertainty growing by ``initial_speed_std_mps`` x t; two of those standard
    deviations reach ~10 m at the end of the horizon, and the ``improved`` planner, whose
    clearance margin widens with them, swerved from obstacles 10 m away at their first
    sighting (Fig. 7.2: tracking RMSE 0.92 m, 0.38 m without it). Such a track is planned
    with its next step's uncertainty at every step: the next sample gives it a velocity."""
    covs_m2 = np.asarray(covs_m2)
    return covs_m2 if initialised else np.repeat(covs_m2[:1], len(covs_m2), axis=0)


def worst_std_m(covs_m2) -> np.ndarray:
    """Standard deviation of predicted positions along their worst direction: the square
    root of the largest eigenvalue of each 2x2 covariance (last two axes), in closed form.
    The planner's clearance margin and the safety check both widen by it."""
    c = np.asarray(covs_m2, dtype=float)
    a, b, d = c[..., 0, 0], c[..., 0, 1], c[..., 1, 1]
    return np.sqrt(np.maximum((a + d) * 0.5 + np.hypot((a - d) * 0.5, b), 0.0))


def obstacle_model_step(s: np.ndarray, sample_time_s: float) -> np.ndarray:
    """One step of the paper's obstacle model on an array of states (last axis of size 5)."""
    x, y, v, th, dth = np.moveaxis(np.asarray(s, dtype=float), -1, 0)
    th1 = th + dth
    return np.stack(
        [x + v * sample_time_s * np.cos(th1), y + v * sample_time_s * np.sin(th1), v, th1, dth], axis=-1
    )


def _jacobian(s: np.ndarray, T: float) -> np.ndarray:
    """The model's Jacobian at state ``s`` (the filter uses its closed form,
    :func:`casadi_gpc.estimation.ekf_floats.propagate`; this matrix form is kept for tests and readers)."""
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
    max_maneuver_mps: float = 1.5
    """The largest change of velocity an obstacle makes within one sample: two measurements
    beyond the gate in a row, the second within this times T of the first, are a manoeuvre (a
    stop, a swerve) or a jump (the id names someone elsewhere), the velocity estimated from the
    two; a lone one is a sensor glitch."""
    max_rejections: int = 3
    """After this many outliers in a row (that do not agree) the track restarts at the new
    measurement."""

    def __post_init__(self):
        """Every number finite and not negative, the gate above 0 and ``max_rejections`` a whole
        number: a ValueError naming the field (until 2026-12-02 a negative or NaN noise level was
        taken, and the filter's covariances were nonsense)."""
        for f in fields(self):
            value = getattr(self, f.name)
            if not (finite_real(value) and value >= 0):
                raise ValueError(f"EKFSettings.{f.name} must be a finite number, not negative, got {value!r}")
        if self.gate_chi2 <= 0:
            raise ValueError(f"EKFSettings.gate_chi2 must be above 0, got {self.gate_chi2!r}")
        if self.max_rejections != int(self.max_rejections):
            raise ValueError(f"EKFSettings.max_rejections must be a whole number, got {self.max_rejections!r}")

    def for_sample_time(self, sample_time_s: float, reference_sample_time_s: float = 0.5) -> "EKFSettings":
        """These settings, meant per step of ``reference_sample_time_s`` (the ``improved``
        planner's 0.5 s), for a filter stepped every ``sample_time_s`` with the same noise
        per second: the random walks of position and heading keep their variance per second
        (std x sqrt(T / T0)), the speed's too (std x sqrt(T0 / T), as its std per step is
        this times T), and the turn increment, a turn rate times T, keeps its turn rate's
        (std x (T / T0)^1.5; its initial std x T / T0). Without this a filter stepped every
        0.1 s forecasts 6 s ahead with a heading lost entirely (the turn increment's random
        walk summed over 60 steps instead of 12)."""
        r = float(sample_time_s) / float(reference_sample_time_s)
        if not (math.isfinite(r) and r > 0):
            raise ValueError(f"sample times must be positive, got {sample_time_s} and {reference_sample_time_s}")
        if r == 1.0:
            return self
        return replace(self, speed_noise_mps2=self.speed_noise_mps2 / math.sqrt(r),
                       turn_noise_rad=self.turn_noise_rad * r ** 1.5,
                       heading_noise_rad=self.heading_noise_rad * math.sqrt(r),
                       position_noise_m=self.position_noise_m * math.sqrt(r),
                       initial_turn_std_rad=self.initial_turn_std_rad * r)


def _q_diagonal(settings: EKFSettings, sample_time_s: float) -> tuple[float, float, float, float, float]:
    """The diagonal of the process noise Q."""
    st, T = settings, sample_time_s
    return (st.position_noise_m ** 2, st.position_noise_m ** 2, (st.speed_noise_mps2 * T) ** 2,
            st.heading_noise_rad ** 2, st.turn_noise_rad ** 2)


def straightened(state: tuple, cov_upper: tuple, q: tuple) -> tuple[tuple, tuple, tuple]:
    """The filter's estimate made a constant-velocity forecast's start: the turn increment
    set to zero with no uncertainty (its row and column of the covariance, and its process
    noise, zeroed), so that the model's step moves on at the estimated speed and heading, its
    uncertainty growing from theirs and from the heading's random walk.

    The paper's model turns on by the estimated turn increment. Real people do not keep a
    turn: over the UCY recordings, 8 positions observed and 12 forecast 0.4 s apart
    (``tools/forecast_accuracy.py``), the turning forecast's ADE is 0.48-0.85 m against
    0.39-0.74 m for the same filter's straight one (docs/pedestrians.md)."""
    x, y, v, th, _ = state
    u = list(cov_upper)
    for i in _TURN_ENTRIES:
        u[i] = 0.0
    return (x, y, v, th, 0.0), tuple(u), straight_noise(q)


_TURN_ENTRIES = (4, 8, 11, 13, 14)
"""The entries of the covariance's upper triangle (:data:`casadi_gpc.estimation.ekf_floats.upper`)
in the turn increment's row and column."""


def standing_forecasts(rows, settings: "EKFSettings", sample_time_s: float,
                       horizon: int) -> tuple[np.ndarray, np.ndarray]:
    """The forecast of tracks seen once, standing where they were seen, the uncertainty growing
    with the unknown speed (at step j, the position's covariance plus I times
    ``(initial_speed_std_mps * T * j) ** 2``): means ``(N, H, 2)`` and covariances ``(N, H, 2,
    2)`` of the rows ``(N, 20)`` (state, then the covariance's upper triangle, as a bank holds
    them), every row and step at once (a step, or a track, at a time it was most of a decision
    whose crowd had just come into view). :meth:`FilterState.predict`'s numbers for such a
    track: it calls this with its one row."""
    rows = np.asarray(rows, dtype=float).reshape(-1, 20)
    grow = (settings.initial_speed_std_mps * sample_time_s) ** 2
    steps2 = np.arange(1, horizon + 1, dtype=float) ** 2
    pos_cov = rows[:, (5, 6, 6, 10)].reshape(-1, 1, 2, 2)  # P[:2, :2] from the upper triangle
    covs = pos_cov + (np.eye(2) * grow) * steps2[:, None, None]
    return np.repeat(rows[:, None, :2], horizon, axis=1), covs


def _readonly(values, shape: tuple) -> np.ndarray:
    a = np.array(values).reshape(shape)
    a.flags.writeable = False
    return a


class FilterState(NamedTuple):
    """A filter's estimate at one sample, frozen, in plain floats: what
    :meth:`ObstacleEKF.snapshot <casadi_gpc.estimation.ekf.ObstacleEKF.snapshot>` hands out, so that a forecast can be made from it later
    (:meth:`predict` gives :meth:`ObstacleEKF.predict <casadi_gpc.estimation.ekf.ObstacleEKF.predict>`'s numbers at the time of the
    snapshot)."""

    state: tuple
    """``(x, y, V, theta, dtheta)``."""
    cov_upper: tuple
    """The covariance's upper triangle, 15 floats row by row."""
    measurements_seen: int
    sample_time_s: float
    settings: EKFSettings

    @property
    def initialised(self) -> bool:
        return self.measurements_seen >= 2

    def state_array(self) -> np.ndarray:
        return np.array(self.state)

    def cov_array(self) -> np.ndarray:
        return _cov_array(self.cov_upper)

    def predict(self, horizon: int, q: tuple | None = None, forecast=None,
                straight: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Predicted positions ``(H, 2)`` and their covariances ``(H, 2, 2)`` for steps 1..H
        (``q``: the diagonal of Q when the caller has it). ``forecast``: a callable
        ``(state, cov_upper, T, q, horizon) -> (means, covs)`` giving :func:`propagate`'s
        numbers faster (:class:`casadi_gpc.estimation.forecast_function.ForecastFunction`), for a
        track seen twice or more. ``straight``: the forecast holds the estimated speed and
        heading (:func:`straightened`) instead of turning on by the turn increment."""
        T = self.sample_time_s
        if self.measurements_seen == 1:  # standing where it was seen
            means, covs = standing_forecasts((*self.state, *self.cov_upper), self.settings, T, horizon)
            return means[0], covs[0]
        q = q or _q_diagonal(self.settings, T)
        if straight:
            state, cov_upper, q = straightened(self.state, self.cov_upper, q)
            return (forecast or _forecast)(state, cov_upper, T, q, horizon)
        return (forecast or _forecast)(self.state, self.cov_upper, T, q, horizon)
