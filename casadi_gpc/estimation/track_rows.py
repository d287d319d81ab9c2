"""The deployed policy's bank of obstacle filters, its estimates held as rows of one array from
sample to sample (numpy and numba only).

:class:`~casadi_gpc.estimation.tracking.TrackBank` steps its crowd's filters together too, but
gathers each filter's floats into an array and scatters the answer back into the filters at
every sample: in a decision among ten walkers that was most of the estimation's time
(docs/nn-deploy.md, "Time"). Here the array is the estimate. Each filter's row holds its state,
its covariance's upper triangle and what its step writes with them; a sample's initialised
tracks with a finite measurement are stepped in place by one compiled call
(:func:`~casadi_gpc.estimation.ekf_floats.step_rows`: the filter's propagation and
:func:`~casadi_gpc.estimation.ekf_floats.correct`). Everything else is the filter's own
:meth:`~casadi_gpc.estimation.ekf.ObstacleEKF.step` (the one definition of the gate's
outcomes, the misses and the starts), its floats taken from its row before and put back after:
a measurement gated out (an outlier, a manoeuvre, a restart), a missing one, a track's first
two sightings. The filters' objects keep what only their own step changes (how often they
have been seen, their counts, a pending measurement).

The same events, counts, ghosts and estimates as :class:`TrackBank`, bit for bit
(``tests/test_track_rows.py``).
"""
from __future__ import annotations

import math
from collections.abc import Iterable
from typing import NamedTuple

import numpy as np

from .ekf import EKFSettings, ObstacleEKF
from .ekf_floats import frame_rows, step_frame_rows, step_rows
from .ekf_batch import MANY_TRACKS
from .tracking import TRACK_COUNTERS, counted, missed_steps
from ..types import ObstacleMeasurement

__all__ = ["RowBank", "SeenRows", "ROW_WIDTH"]

ROW_WIDTH = 23
"""A filter's row: the state ``(x, y, V, theta, dtheta)`` (5), its covariance's upper triangle
(15, :data:`~casadi_gpc.estimation.ekf_floats.upper`), the last fused position (2) and the samples
since it (1)."""


class SeenRows(NamedTuple):
    """One sample's tracks that have a state, then their ghosts (:meth:`RowBank.step`)."""

    measurements: list
    """The :class:`~casadi_gpc.types.ObstacleMeasurement` of each (a ghost: its track's)."""
    rows: np.ndarray
    """``(n, 20)``: each one's state and covariance's upper triangle at this sample (a copy:
    the bank moves on)."""
    seen: list
    """How many positions each has fused (1: speed and heading unknown, planned standing)."""
    forecasts: tuple | None = None
    """Where the bank was given a horizon H, the sample has at least
    :data:`~casadi_gpc.estimation.ekf_batch.MANY_TRACKS` tracks (fewer are forecast one by one,
    when read) and no ghost was added: every row's forecast made as
    if it had been seen twice, :func:`~casadi_gpc.estimation.ekf_floats.forecast_rows`' means
    ``(n, H, 2)`` and covariances ``(n, H, 2, 2)``, and their worst deviations ``(n, H)``
    (:func:`~casadi_gpc.estimation.ekf_floats.frame_rows`: in the one call that copies the rows
    out); None otherwise."""


class RowBank:
    """One obstacle EKF per obstacle id, made at its first measurement, its estimate held as a
    row of the bank's array (module docstring); ``step`` once per sample.

    Parameters
    ----------
    sample_time_s : float
        T, the filters' step (fixed for the bank's life, as its settings).
    settings : EKFSettings, optional
        The filters' noise levels.
    counters : dict, optional
        Where to count the events of :data:`~casadi_gpc.estimation.tracking.TRACK_COUNTERS`.
    horizon : int, optional
        H: each step also gives the rows' H-step forecasts (:attr:`SeenRows.forecasts`).
    """

    def __init__(self, sample_time_s: float, settings: EKFSettings | None = None, counters: dict | None = None,
                 horizon: int | None = None):
        self.sample_time_s = sample_time_s
        self.horizon = None if horizon is None else int(horizon)
        self.settings = settings or EKFSettings()
        self.counters = {} if counters is None else counters
        for k in TRACK_COUNTERS:
            self.counters.setdefault(k, 0)
        self._filters: dict[int, ObstacleEKF] = {}
        self.last_t_s: float | None = None  # the time of the last step that said it (missed_steps)
        self._slots: dict[int, tuple[ObstacleEKF, int]] = {}  # obstacle id -> (its filter, its row)
        self._array = np.zeros((16, ROW_WIDTH))
        self._used = 0  # rows ever handed out
        self._free: list[int] = []  # the rows of forgotten tracks
        self._dirty: set[int] = set()  # rows whose filter holds a pending measurement or rejections in a row
        _, T, q, r = ObstacleEKF(sample_time_s, self.settings)._constants()
        self._constants = (float(T), *(float(v) for v in q), float(r), float(self.settings.gate_chi2))
        self._q = np.array(q, dtype=float)

    @property
    def filters(self) -> dict[int, ObstacleEKF]:
        """The filters by obstacle id, their estimates brought up to date from their rows."""
        for ekf, i in self._slots.values():
            if ekf.measurements_seen_ >= 2:
                self._check_out(ekf, i)
        return dict(self._filters)

    def step(self, moving: Iterable[ObstacleMeasurement], t_s: float | None = None) -> SeenRows:
        """Fuse one sample's measurements (one step of every measured obstacle's filter), taken at
        ``t_s``: :meth:`TrackBank.step <casadi_gpc.estimation.tracking.TrackBank.step>`'s tracks and
        ghosts, in its order, as rows (the samples missed before it too)."""
        slots, isfinite = self._slots, math.isfinite
        for _ in range(missed_steps(self, t_s)):
            for ekf, i in list(slots.values()):
                self._own_step(ekf, i, None)
        order, fs, ms, together, jobs = [], [], [], [], []
        listed = 0
        for m in moving:
            listed += 1
            slot = slots.get(m.obstacle_id)
            if slot is None:
                slot = self._add(m.obstacle_id)
            ekf, i = slot
            z = m.position_m
            if ekf.measurements_seen_ >= 2 and type(z) is tuple and len(z) == 2 and type(z[0]) is float \
                    and type(z[1]) is float and isfinite(z[0]) and isfinite(z[1]):
                together.append((ekf, i, z))
                jobs += (i, z[0], z[1])
            elif not self._own_step(ekf, i, z):
                continue
            order.append(i)
            fs.append(ekf)
            ms.append(m)
        frame, H = None, self.horizon  # the rows copied out, and their forecasts where the bank has a horizon
        if H is not None and len(order) < MANY_TRACKS:  # each track's own forecast, when read (row_track_estimates)
            H = None
        if jobs:
            jobs = np.array(jobs).reshape(len(together), 3)
            T, q0, q1, q2, q3, q4, r, gate = self._constants
            if H is None:
                passed = step_rows(self._array, jobs, T, q0, q1, q2, q3, q4, r, gate)
            else:  # stepped and copied out with the forecasts in one compiled call
                passed, *frame = step_frame_rows(self._array, jobs, np.array(order, dtype=np.int64), T, self._q, r,
                                                 gate, H)
            passed = passed.tolist()
            dirty = self._dirty
            if dirty or 0.0 in passed:
                for (ekf, i, z), ok in zip(together, passed):
                    if not ok:  # gated out: the filter's own step (an outlier, a manoeuvre, a restart); still seen
                        self._own_step(ekf, i, z)
                        frame = None  # copied out before it
                    elif i in dirty:  # the update's reset of what the filter's object keeps
                        ekf.pending_z_, ekf._rejections_in_row = None, 0
                        dirty.discard(i)
        if listed < len(slots):
            self._forget(moving)
        seen = [f.measurements_seen_ for f in fs]
        ghosts = [(m, ekf.ghost()) for m, ekf, i in zip(ms, fs, order)
                  if i in self._dirty and ekf.pending_z_ is not None] if self._dirty else None
        if ghosts:
            self.counters["ghosts"] += len(ghosts)
            rows = np.concatenate((self._array[order, :20], np.array([g._s + g._U for _, g in ghosts], dtype=float)))
            forecasts = None
            ms += [m for m, _ in ghosts]
            seen += [g.measurements_seen_ for _, g in ghosts]
        elif H is None:
            rows, forecasts = self._array[order, :20], None
        else:
            if frame is None:
                frame = frame_rows(self._array, np.array(order, dtype=np.int64), self._constants[0], self._q, H)
            rows, forecasts = frame[0], tuple(frame[1:])
        return SeenRows(ms, rows, seen, forecasts)

    def _own_step(self, ekf: ObstacleEKF, i: int, z) -> bool:
        """The filter's own step on ``z``, its floats taken from its row and put back; counted;
        whether the track has a state (is seen)."""
        if ekf.measurements_seen_ >= 2:  # its row may be ahead of the object
            self._check_out(ekf, i)
        event = ekf.step(z)
        if ekf._s is not None:
            lz = ekf._last_z
            self._array[i] = (*ekf._s, *ekf._U, float(lz[0]), float(lz[1]), float(ekf._since_z))
        if ekf.pending_z_ is not None or ekf._rejections_in_row:
            self._dirty.add(i)
        else:
            self._dirty.discard(i)
        return counted(self.counters, ekf, event)

    def _check_out(self, ekf: ObstacleEKF, i: int) -> None:
        """The filter's estimate from its row (the compiled steps write only the row)."""
        r = self._array[i].tolist()
        ekf._s, ekf._U, ekf._state_a, ekf._cov_a = tuple(r[:5]), tuple(r[5:20]), None, None
        ekf._last_z, ekf._since_z = (r[20], r[21]), int(r[22])

    def _add(self, obstacle_id: int) -> tuple[ObstacleEKF, int]:
        ekf = self._filters[obstacle_id] = ObstacleEKF(self.sample_time_s, self.settings)
        if self._free:
            i = self._free.pop()
        else:
            i, self._used = self._used, self._used + 1
            if i == len(self._array):  # room for twice as many
                self._array = np.concatenate((self._array, np.zeros_like(self._array)))
        slot = self._slots[obstacle_id] = (ekf, i)
        return slot

    def _forget(self, moving) -> None:
        """Drop the filters of obstacles the sensor no longer lists, as
        :meth:`TrackBank._forget <casadi_gpc.estimation.tracking.TrackBank._forget>` does: one
        that comes back starts a new track."""
        ids = {m.obstacle_id for m in moving}
        gone = [k for k in self._slots if k not in ids]
        for k in gone:
            _, i = self._slots.pop(k)
            del self._filters[k]
            self._free.append(i)
            self._dirty.discard(i)
        self.counters["dropped_tracks"] = self.counters.get("dropped_tracks", 0) + len(gone)
