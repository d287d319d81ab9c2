"""Extended Kalman filter for one moving obstacle (the paper's section 3).

State ``s = [x, y, V, theta, dtheta]``: position (m), speed (m/s), heading of the last
displacement (rad) and its change per sample (rad/step). Model (constant speed,
constant turn increment), with T the sample time::

    theta' = theta + dtheta
    x'     = x + V T cos(theta')
    y'     = y + V T sin(theta')
    V' = V,  dtheta' = dtheta

Measurements are positions with white noise. An innovation beyond the Mahalanobis gate is
not fused. When the next measurement is gated out too and agrees with it (within what the
obstacle could have done in a sample, ``EKFSettings.max_maneuver_mps``, however far from the
prediction), the obstacle manoeuvred (stopped dead, or set off), or its id now names someone
elsewhere (a tracker that reuses ids): the velocity is estimated afresh from the two, counted;
meanwhile :meth:`ObstacleEKF.ghost` stands at the pending measurement for planners to avoid
too. A run of ``max_rejections`` rejections that do not agree restarts the track at the last
one. The model, its noise levels and the frozen estimate with its forecast are
:mod:`casadi_gpc.estimation.obstacle_model`'s. Numpy only (the deployed policy uses it).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .ekf_floats import (correct as _correct, full as _full, propagate as _propagate, update_rows as _update_rows,
                         upper as _upper)
from .obstacle_model import EKFSettings, FilterState, _q_diagonal, _readonly
# the model's names, where scripts have imported them from (one definition: obstacle_model)
from .obstacle_model import GATE_CHI2_2DOF, obstacle_model_step, planning_covariances, worst_std_m  # noqa: F401

__all__ = ["EKFSettings", "ObstacleEKF", "FilterState", "obstacle_model_step", "planning_covariances", "worst_std_m",
           "GATE_CHI2_2DOF"]


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
    """A measurement gated out at the last step, waiting for the next one to tell a glitch
    from a manoeuvre or a jump (:meth:`ghost`)."""
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
            z = np.array((zx, zy))
            reach = self.settings.max_maneuver_mps * T
            pending = self.pending_z_
            if pending is not None and np.hypot(*(z - pending)) <= reach:
                # Two rejections in a row, the second agreeing with the first: a manoeuvre (a
                # walker that stops dead at its goal, turns, or sets off), or, the first beyond
                # any manoeuvre, a jump (the id now names someone elsewhere). The
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
            # stopped walker was predicted walking on and the planner drove into it) or of a
            # jump. While the next sample decides, it is kept as pending: :meth:`ghost` is the
            # obstacle standing there, for planners to keep clear of as well. (Until 2026-12-02
            # one farther than a manoeuvre was taken for a glitch, without a ghost: an id that
            # came to name a person 3 m away left that person unseen until the third
            # rejection, 1 s at T = 0.5 s.)
            self.pending_z_ = z
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
        """While a gated measurement waits for confirmation (``pending_z_``): a filter of
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
