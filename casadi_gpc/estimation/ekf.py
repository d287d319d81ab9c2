"""Extended Kalman filter for one moving obstacle (the paper's section 3).

State ``s = [x, y, V, theta, dtheta]``: position (m), speed (m/s), heading of the last
displacement (rad) and its change per sample (rad/step). Model (constant speed,
constant turn increment), with T the sample time::

    theta' = theta + dtheta
    x'     = x + V T cos(theta')
    y'     = y + V T sin(theta')
    V' = V,  dtheta' = dtheta

Measurements are positions with white noise. An innovation beyond the Mahalanobis gate is
not fused. When it is within what the obstacle could have done in a sample
(``EKFSettings.max_maneuver_mps``) and the next measurement is gated out too and agrees with
it (however far from the prediction), the obstacle manoeuvred (stopped dead, or set off): the
velocity is estimated afresh from the two, counted; meanwhile :meth:`ObstacleEKF.ghost` stands
at the pending measurement for planners to avoid too. A run of ``max_rejections``
rejections restarts the track at the last one. Numpy only (the deployed policy uses it).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from .ekf_floats import (correct as _correct, cov_array as _cov_array, forecast as _forecast, full as _full,
                         propagate as _propagate, straight_noise, update_rows as _update_rows,
                         upper as _upper)

__all__ = ["EKFSettings", "ObstacleEKF", "FilterState", "obstacle_model_step", "planning_covariances", "worst_std_m",
           "GATE_CHI2_2DOF"]

GATE_CHI2_2DOF = 18.42  # chi-square(2) 0.9999 quantile: an innovation beyond it is an outlier


def planning_covariances(covs_m2: np.ndarray, initialised: bool) -> np.ndarray:
    """The forecast covariances a planner uses. For a track seen once (speed and heading
    unknown, :attr:`ObstacleEKF.initialised` false) the filter predicts the obstacle standing
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
    """The largest change of velocity an obstacle makes within one sample: a measurement
    beyond the gate but nearer its prediction than this times T may be a manoeuvre (a stop, a
    swerve), which the next measurement confirms; a farther one is a sensor glitch."""
    max_rejections: int = 3
    """After this many outliers in a row the track restarts at the new measurement."""

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


def _readonly(values, shape: tuple) -> np.ndarray:
    a = np.array(values).reshape(shape)
    a.flags.writeable = False
    return a


class FilterState(NamedTuple):
    """A filter's estimate at one sample, frozen, in plain floats: what
    :meth:`ObstacleEKF.snapshot` hands out, so that a forecast can be made from it later
    (:meth:`predict` gives :meth:`ObstacleEKF.predict`'s numbers at the time of the
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
        if self.measurements_seen == 1:
            # standing where it was seen, the uncertainty growing with the unknown speed: at step
            # j, P[:2, :2] + I grow j^2, all steps at once (a step at a time it was most of a
            # decision whose crowd had just come into view)
            grow = (self.settings.initial_speed_std_mps * T) ** 2
            steps2 = np.arange(1, horizon + 1, dtype=float) ** 2
            covs = self.cov_array()[:2, :2] + (np.eye(2) * grow) * steps2[:, None, None]
            return np.tile(np.array(self.state[:2], dtype=float), (horizon, 1)), covs
        q = q or _q_diagonal(self.settings, T)
        if straight:
            state, cov_upper, q = straightened(self.state, self.cov_upper, q)
            return (forecast or _forecast)(state, cov_upper, T, q, horizon)
        return (forecast or _forecast)(self.state, self.cov_upper, T, q, horizon)


@dataclass
class ObstacleEKF:
    """Track of one moving obstacle. ``step`` once per sample, then ``predict``.

    The filter computes in plain floats (the deployed policy runs it every sample, and
    numpy's per-call cost on 5-vectors was most of that time); :attr:`state_` and
    :attr:`cov_` are read-only arrays made from them when read. Assigning either replaces
    the estimate (only the covariance's upper triangle is used, as the filter always did).
    """

    sample_time_s: float
    settings: EKFSettings = field(default_factory=EKFSettings)
    measurements_seen_: int = 0
    missed_: int = 0
    outliers_: int = 0
    maneuvers_: int = 0
    _last_z: tuple | np.ndarray | None = None
    """The last fused position ``(x, y)``."""
    _rejections_in_row: int = 0
    _since_z: int = 0  # samples since the last fused measurement (_last_z)
    pending_z_: np.ndarray | None = None
    """A plausible measurement gated out at the last step, waiting for the next one to tell a
    glitch from a manoeuvre (:meth:`ghost`)."""
    _steps_since_first: int = 1  # samples between the first and the second measurement
    _s: tuple | None = field(default=None, repr=False)
    """The state ``(x, y, V, theta, dtheta)`` in plain floats; None before the first measurement."""
    _U: tuple | None = field(default=None, repr=False)
    """The covariance's upper triangle in plain floats (:data:`casadi_gpc.estimation.ekf_floats.upper`)."""

    def __post_init__(self):
        self._consts = (None, None, None, None)
        self._state_a = self._cov_a = None  # state_ and cov_, once made from _s and _U

    # --- the estimate as arrays ------------------------------------------------------
    @property
    def state_(self) -> np.ndarray | None:
        """State ``[x, y, V, theta, dtheta]``, shape (5,), read-only; None before the first
        measurement."""
        if self._s is None:
            return None
        a = self._state_a
        if a is None:
            a = self._state_a = _readonly(self._s, (5,))
        return a

    @state_.setter
    def state_(self, value) -> None:
        if value is None:
            self._s = None
        else:
            a = np.asarray(value, dtype=float)
            if a.shape != (5,):
                raise ValueError(f"an obstacle state has 5 entries, got shape {a.shape}")
            self._s = tuple(a.tolist())
        self._state_a = self._cov_a = None

    @property
    def cov_(self) -> np.ndarray | None:
        """Its covariance, shape (5, 5), read-only (None before the first measurement)."""
        if self._U is None:
            return None
        a = self._cov_a
        if a is None:
            a = self._cov_a = _readonly(_full(self._U), (5, 5))
        return a

    @cov_.setter
    def cov_(self, value) -> None:
        if value is None:
            self._U = None
        else:
            a = np.asarray(value, dtype=float)
            if a.shape != (5, 5):
                raise ValueError(f"an obstacle covariance is 5x5, got shape {a.shape}")
            self._U = _upper(a.ravel().tolist())
        self._state_a = self._cov_a = None

    def _set(self, s: tuple, U: tuple) -> None:
        self._s, self._U = s, U
        self._state_a = self._cov_a = None

    def snapshot(self) -> FilterState:
        """The estimate now, frozen (its forecast can be made later: :meth:`FilterState.predict`)."""
        if self._s is None:
            raise RuntimeError("snapshot() before any measurement")
        # FilterState(...) without its Python-level __new__ (the deployed policy takes one a sample)
        return tuple.__new__(FilterState, (self._s, self._U, self.measurements_seen_, self.sample_time_s,
                                           self.settings))

    # --- settings --------------------------------------------------------------------
    def _R(self) -> np.ndarray:
        return np.eye(2) * self._r()

    def _r(self) -> float:
        """Variance of each measured coordinate."""
        return self._constants()[3]

    def _q(self) -> tuple[float, float, float, float, float]:
        """The diagonal of Q."""
        return self._constants()[2]

    def _constants(self) -> tuple:
        """``(settings, T, diagonal of Q, r)``, made again only when the settings or T
        change (they are fixed for a filter's life, as a rule)."""
        c = self._consts
        if c[0] is not self.settings or c[1] != self.sample_time_s:
            st, T = self.settings, self.sample_time_s
            c = self._consts = (st, T, _q_diagonal(st, T), max(st.measurement_std_m, 1e-3) ** 2)
        return c

    def _Q(self) -> np.ndarray:
        return np.diag(self._q())

    @property
    def initialised(self) -> bool:
        return self.measurements_seen_ >= 2

    @property
    def started(self) -> bool:
        """Whether the filter has an estimate (it has fused a first measurement)."""
        return self._s is not None

    @property
    def velocity_mps(self) -> tuple[float, float]:
        """The estimated velocity ``(vx, vy)`` in the world frame, m/s: speed times heading;
        ``(0, 0)`` for a track seen once (it has no velocity yet, and is planned standing)."""
        if self._s is None or not self.initialised:
            return 0.0, 0.0
        v, heading = self._s[2], self._s[3]
        return v * math.cos(heading), v * math.sin(heading)

    # --- the filter ------------------------------------------------------------------
    def _start(self, z) -> None:
        st = self.settings
        r = max(st.measurement_std_m, 1e-3) ** 2
        # np.diag([r, r, sv^2, pi^2, st^2]) as an upper triangle
        self._set((float(z[0]), float(z[1]), 0.0, 0.0, 0.0),
                  (r, 0.0, 0.0, 0.0, 0.0, r, 0.0, 0.0, 0.0, st.initial_speed_std_mps ** 2, 0.0, 0.0, np.pi ** 2, 0.0,
                   st.initial_turn_std_rad ** 2))
        self.measurements_seen_ = 1
        self._last_z = z
        self._since_z = 0
        self.pending_z_ = None
        self._rejections_in_row = 0
        self._steps_since_first = 1

    def _second(self, z: np.ndarray) -> None:
        """Two positions give speed and heading by finite difference."""
        st = self.settings
        T = self.sample_time_s * self._steps_since_first  # missed samples in between lengthen the baseline
        d = z - np.asarray(self._last_z, dtype=float)
        v = float(np.hypot(*d)) / T
        r = max(st.measurement_std_m, 1e-3) ** 2
        var_v = 2.0 * r / T ** 2
        var_th = min(np.pi ** 2, 2.0 * r / max(v * T, 1e-6) ** 2)
        self._set((float(z[0]), float(z[1]), v, float(np.arctan2(d[1], d[0])), 0.0),
                  (r, 0.0, 0.0, 0.0, 0.0, r, 0.0, 0.0, 0.0, var_v, 0.0, 0.0, var_th, 0.0, st.initial_turn_std_rad ** 2))
        self.measurements_seen_ = 2

    def step(self, z) -> str:
        """Advance one sample and fuse measurement ``z`` (``None`` or non-finite = missing).

        Returns what happened: ``"start"``, ``"update"``, ``"missed"``, ``"outlier"`` or
        ``"manoeuvre"``. Raises ``ValueError`` when ``z`` is not a position (two numbers).
        """
        if type(z) is tuple and len(z) == 2 and type(z[0]) is float and type(z[1]) is float:
            zx, zy = z  # the sensor's own form: no array needed
            if not (math.isfinite(zx) and math.isfinite(zy)):
                z = None
        elif z is not None:
            z = np.asarray(z, dtype=float)
            if z.shape != (2,):
                raise ValueError(f"an obstacle measurement is a position (x, y), got shape {z.shape}")
            zx, zy = float(z[0]), float(z[1])
            if not (math.isfinite(zx) and math.isfinite(zy)):
                z = None
        if self._s is None:
            if z is None:
                self.missed_ += 1
                return "missed"
            self._start(np.array((zx, zy)))
            return "start"
        if self.measurements_seen_ == 1:
            if z is None:
                self.missed_ += 1
                self._steps_since_first += 1
                # a stationary guess whose uncertainty grows with the unknown speed: P[:2, :2] +=
                # g I (numpy's numbers: the off-diagonal gets + 0.0)
                g = (self.settings.initial_speed_std_mps * self.sample_time_s) ** 2
                U = self._U
                self._set(self._s, (U[0] + g, U[1] + 0.0, *U[2:5], U[5] + g, *U[6:]))
                return "missed"
            z = np.array((zx, zy))
            self._second(z)
            self._last_z, self._since_z = z, 0
            return "update"
        # propagation (plain floats: see ekf_floats.propagate)
        c = self._consts
        if c[0] is not self.settings or c[1] != self.sample_time_s:
            c = self._constants()
        x, y, v, th, dth = self._s
        x, y, th, U = _propagate(x, y, v, th, dth, self._U, c[1], c[2], 1)
        if z is None:
            self._set((x, y, v, th, dth), U)
            self.missed_ += 1
            self._since_z += 1
            self.pending_z_ = None
            return "missed"
        # correction, with an innovation gate against outliers
        passed, corrected, N = _correct(x, y, v, th, dth, U, zx, zy, c[3], self.settings.gate_chi2)
        if not passed:
            T = self.sample_time_s
            i0, i1 = zx - x, zy - y
            z = np.array((zx, zy))
            reach = self.settings.max_maneuver_mps * T
            plausible = i0 * i0 + i1 * i1 <= reach * reach
            pending = self.pending_z_
            if pending is not None and np.hypot(*(z - pending)) <= reach:
                # Two rejections in a row, the first plausible, the second agreeing with it: a
                # manoeuvre (a walker that stops dead at its goal, turns, or sets off). The
                # constant-velocity model has no say in it: the velocity is estimated afresh
                # from the two. The second is judged by the first, not by the prediction: a
                # person setting off at 0.7 m/s is 0.76 m from the stale one a second on, and
                # was forecast standing where they had been until a restart (docs/model.md).
                self.maneuvers_ += 1
                self._last_z, self._steps_since_first = pending, 1
                self._second(z)
                self._last_z, self._since_z, self._rejections_in_row, self.pending_z_ = z, 0, 0, None
                return "manoeuvre"
            # Not fused: a sensor glitch, or the first sample of a manoeuvre (a walker that stops
            # is 0.25 m from its prediction after 0.5 s; gated out three times in a row, a
            # stopped walker was predicted walking on and the planner drove into it). While
            # the next sample decides, a plausible one is kept as pending: :meth:`ghost` is
            # the obstacle standing there, for planners to keep clear of as well.
            self.pending_z_ = z if plausible else None
            self._set((x, y, v, th, dth), U)
            self.outliers_ += 1
            self._rejections_in_row += 1
            self._since_z += 1
            if self._rejections_in_row >= self.settings.max_rejections:
                self._start(z)  # the obstacle really is somewhere else: start over
                return "start"
            return "outlier"
        self._accept(corrected, N, (zx, zy))
        return "update"

    def _accept(self, s: tuple, U: tuple, z: tuple) -> None:
        """Take the corrected estimate ``s``, ``U`` of the measurement ``z`` (an update)."""
        self.pending_z_ = None
        self._rejections_in_row = 0
        self._s, self._U, self._state_a, self._cov_a = s, U, None, None  # _set, written out (every sample)
        self._last_z, self._since_z = z, 0

    @staticmethod
    def update_together(filters: list, zs: list) -> list:
        """:meth:`step` of initialised filters (same settings and sample time) on finite positions
        ``zs``, in one compiled call (``update_rows`` of :mod:`.ekf_floats`, bit for bit): those
        passing the gate are updated, the others left as they were for their own ``step``; returns
        which were updated (ten steps in Python floats: some 60 us of a decision among ten walkers)."""
        f0 = filters[0]
        _, T, q, r = f0._constants()
        flat = []  # one array in, one out (each numpy call costs more than the arithmetic here)
        for f, z in zip(filters, zs):
            flat += (*f._s, *f._U, *z)
        out = _update_rows(np.array(flat).reshape(len(filters), 22), T, *q, r, f0.settings.gate_chi2).tolist()
        for f, row, z in zip(filters, out, zs):
            if row[0]:
                f._accept(tuple(row[1:6]), tuple(row[6:]), z)
        return [row[0] == 1.0 for row in out]

    def ghost(self) -> "ObstacleEKF | None":
        """While a plausible measurement waits for confirmation (``pending_z_``): a filter of
        the obstacle standing there, as if it had stopped (its speed as uncertain as two equal
        measurements leave it), for a planner to keep clear of beside the track itself; else
        None."""
        if self.pending_z_ is None:
            return None
        g = ObstacleEKF(self.sample_time_s, self.settings)
        g._start(self.pending_z_)
        g._second(self.pending_z_)
        return g

    def predict(self, horizon: int, forecast=None, straight: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Predicted positions ``(H, 2)`` and their covariances ``(H, 2, 2)`` for steps 1..H
        (``forecast``, ``straight``: see :meth:`FilterState.predict`)."""
        if self._s is None:
            raise RuntimeError("predict() before any measurement")
        return FilterState(self._s, self._U, self.measurements_seen_, self.sample_time_s,
                           self.settings).predict(horizon, self._q(), forecast, straight)
