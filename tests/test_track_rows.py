"""The bank held as rows (casadi_gpc.estimation.track_rows.RowBank, the deployed tracker's)
against the bank of filter objects (TrackBank, the planner's), stepped side by side on random
crowds: misses (None and not finite), gated glitches, restarts, walkers that stop dead, one that
appears late, one that vanishes and comes back, positions that are not the sensor's tuples. The
same tracks in the same order, the same floats to the bit, the same counters and ghosts; and
the deployed track estimates made from the rows, the same as made from the filters."""
from __future__ import annotations

from unittest import mock

import numpy as np
import pytest

from casadi_gpc.estimation import tracking
from casadi_gpc.estimation.ekf import EKFSettings, ObstacleEKF
from casadi_gpc.estimation.ekf_floats import forecast_rows, worst_std_rows
from casadi_gpc.estimation.track_rows import RowBank
from casadi_gpc.estimation.tracking import TrackBank
from casadi_gpc.safety.check import forecast_arrays, shared_batch
from casadi_gpc.types import ObstacleMeasurement
from nn_export.runtime.situation import row_track_estimates, track_estimates


def _fields(f) -> dict:
    """Everything a filter holds (positions as float tuples, whatever their container)."""
    d = {k: v for k, v in vars(f).items() if k not in ("_state_a", "_cov_a", "_consts", "_last_z", "pending_z_")}
    d["_last_z"] = None if f._last_z is None else tuple(np.asarray(f._last_z, dtype=float).tolist())
    d["pending_z_"] = None if f.pending_z_ is None else tuple(np.asarray(f.pending_z_, dtype=float).tolist())
    return d


def _crowd(rng, n: int, samples: int, T: float):
    """A random sequence of samples of ``n`` walkers (see the module docstring)."""
    pos = {i: rng.normal(0, 4, 2) for i in range(n)}
    vel = {i: rng.normal(0, 0.5, 2) for i in range(n)}
    late, gone, stops = n - 1, n - 2, int(rng.integers(0, max(n - 2, 1)))
    stop_at, burst = int(rng.integers(5, samples // 2)), int(rng.integers(5, samples - 5))
    out = []
    for k in range(samples):
        moving = []
        for i in range(n):
            if (i == late and k < samples // 4) or (i == gone and samples // 3 <= k < samples // 3 + 4) \
                    or (i == gone and k > samples - 5):
                continue
            pos[i] = pos[i] + vel[i] * T
            if i == stops and k == stop_at:
                vel[i] = np.zeros(2)  # stops dead: a manoeuvre
            if rng.random() < 0.03:
                vel[i] = rng.normal(0, 0.5, 2)  # a swerve
            z = pos[i] + rng.normal(0, 0.02, 2)
            u = rng.random()
            if u < 0.05 or (i == 0 and burst <= k < burst + 3):
                z = z + rng.normal(0, 3, 2)  # a glitch (three in a row: a restart)
            elif u < 0.07:
                z = z + rng.normal(0, 0.3, 2)  # near: a plausible rejection, a ghost
            m = (float(z[0]), float(z[1]))
            u = rng.random()
            if u < 0.04:
                m = None
            elif u < 0.06:
                m = (float("nan"), m[1])
            elif u < 0.08:
                m = np.array(m)  # not the sensor's tuple: the filter's own step
            moving.append(ObstacleMeasurement(i, m, 0.25 + 0.01 * i))
        out.append(moving)
    return out


@pytest.mark.parametrize("n, seed", [(1, 0), (3, 1), (5, 2), (10, 3), (10, 4), (14, 5), (30, 6)])
@pytest.mark.parametrize("one_by_one", [False, True])
def test_the_rows_are_the_filter_banks_bit_for_bit(n, seed, one_by_one):
    rng = np.random.default_rng(100 + seed)
    T = 0.5
    settings = EKFSettings()
    rows, objects = RowBank(T, settings, horizon=None if one_by_one else 12), TrackBank(T, settings)
    q = np.array(ObstacleEKF(T, settings)._q())
    for moving in _crowd(rng, n, 80, T):
        seen = rows.step(moving)
        if one_by_one:
            with mock.patch.object(tracking, "UPDATED_TOGETHER", 10 ** 9):
                pairs = objects.step(moving)
        else:
            pairs = objects.step(moving)
        assert seen.measurements == [m for m, _ in pairs]
        assert seen.seen == [f.measurements_seen_ for _, f in pairs]
        assert seen.rows.shape == (len(pairs), 20)
        assert seen.rows.tolist() == [list(f._s + f._U) for _, f in pairs]  # the floats themselves
        assert rows.counters == objects.counters
        if seen.forecasts is not None:  # made in the step: the rows' own (ekf_floats.forecast_rows, worst_std_rows)
            means, covs = forecast_rows(seen.rows[:, :5], seen.rows[:, 5:], T, q, 12)
            assert all(np.array_equal(x, y) for x, y in zip(seen.forecasts, (means, covs, worst_std_rows(covs))))
        filters = rows.filters  # brought up to date from the rows
        assert filters.keys() == objects.filters.keys()
        assert all(_fields(filters[k]) == _fields(f) for k, f in objects.filters.items())
    c = rows.counters
    assert c["outliers"] and c["missed_measurements"] and c["ghosts"] and (c["manoeuvres"] or n < 5)
    assert c.get("dropped_tracks") or n < 3


@pytest.mark.parametrize("made", [True, False])
def test_the_track_estimates_from_the_rows_are_the_filters(made):
    """row_track_estimates (the deployed tracker's) against track_estimates of the filter bank's
    pairs: the same ids, radii, states, covariances, forecasts, planning covariances and worst
    deviations to the bit, a crowd's batched and a few tracks' one by one; with the forecasts
    made in the bank's step (``made``: a bank given the horizon, ekf_floats.frame_rows) or from
    the rows when first read."""
    rng = np.random.default_rng(9)
    T, H = 0.5, 12
    rows, objects = RowBank(T, horizon=H if made else None), TrackBank(T)
    batched = given = 0
    for moving in _crowd(rng, 9, 60, T):
        seen = rows.step(moving)
        given += seen.forecasts is not None
        a = row_track_estimates(seen, rows.sample_time_s, rows.settings, H)
        b = track_estimates(objects.step(moving), H)
        assert len(a) == len(b)
        for s, t in zip(a, b):
            assert (s.obstacle_id, s.radius_m, s.initialised, s.state_values) == \
                   (t.obstacle_id, t.radius_m, t.initialised, t.state_values)
            assert np.array_equal(s.state, t.state) and np.array_equal(s.cov, t.cov)
            assert np.array_equal(s.means_m, t.means_m) and np.array_equal(s.covs_m2, t.covs_m2)
            assert (s.batch_ is None) == (t.batch_ is None)
        if a and shared_batch(a) is not None:
            batched += 1
            for x, y in zip(forecast_arrays(a), forecast_arrays(b)):
                assert np.array_equal(x, y)
    # (a sample with a ghost makes its forecasts when read: since every gated measurement has
    # one, 2026-12-02, some 40 % of these samples, with their 5 % of glitches a walker)
    assert batched > 20 and (given > 20 if made else given == 0)
