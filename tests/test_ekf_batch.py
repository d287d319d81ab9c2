"""The forecasts of many tracks made together (casadi_gpc.estimation.ekf_batch) against the textbook
matrix form step by step, the bank's rows (a track seen once, planning covariances), and
their use by the deployed tracker and the check (the same numbers as track by track)."""
from __future__ import annotations

import numpy as np
import pytest

from casadi_gpc.estimation.ekf import EKFSettings, ObstacleEKF
from casadi_gpc.estimation.obstacle_model import _jacobian, obstacle_model_step
from casadi_gpc.estimation.ekf_batch import MANY_TRACKS, ForecastBatch, forecast_many
from casadi_gpc.estimation.ekf_floats import upper
from casadi_gpc.safety.check import forecast_arrays, forecast_covariances, shared_batch
from casadi_gpc.types import ObstacleMeasurement
from nn_export.runtime.situation import track_estimate, track_estimates


def _random_filters(rng, n: int, T: float, seen_once=()) -> list[ObstacleEKF]:
    """``n`` initialised filters whose state and covariance are replaced by random ones (the
    indices in ``seen_once`` have seen a single position)."""
    out = []
    for i in range(n):
        ekf = ObstacleEKF(T)
        ekf.step((float(rng.normal(0, 5)), float(rng.normal(0, 5))))
        if i not in seen_once:
            ekf.step((ekf.state_[0] + 0.1, ekf.state_[1] - 0.05))
            s = np.array([*rng.normal(0, 5, 2), rng.uniform(0, 1.5), rng.uniform(-4, 4), rng.normal(0, 0.2)])
            L = rng.normal(0, 0.3, (5, 5))
            ekf.state_, ekf.cov_ = s, L @ L.T + 1e-4 * np.eye(5)
        out.append(ekf)
    return out


@pytest.mark.parametrize("T, H", [(0.25, 12), (1.5, 6), (0.5, 1)])
def test_many_forecasts_equal_the_matrix_form_step_by_step(T, H):
    """s' = f(s), P' = F P F^T + Q, H times, for each of 9 random tracks: the closed form over
    the horizon gives the same means and position covariances to rounding."""
    rng = np.random.default_rng(11)
    filters = _random_filters(rng, 9, T)
    means, covs = forecast_many([f.state_ for f in filters], [upper(f.cov_.ravel().tolist()) for f in filters], T,
                                filters[0]._q(), H)
    assert means.shape == (9, H, 2) and covs.shape == (9, H, 2, 2)
    for i, f in enumerate(filters):
        s, P = f.state_.copy(), f.cov_.copy()
        for k in range(H):
            F = _jacobian(s, T)
            s, P = obstacle_model_step(s, T), F @ P @ F.T + f._Q()
            np.testing.assert_allclose(means[i, k], s[:2], rtol=0, atol=1e-12 * (1 + np.abs(s[:2]).max()))
            np.testing.assert_allclose(covs[i, k], P[:2, :2], rtol=0, atol=1e-12 * np.abs(P).max())


def test_the_batch_rows_are_each_filters_own_forecast():
    """A bank's rows: the float form's numbers to rounding, a track seen once its own
    standing forecast (exactly), and its planning covariances held at the first step."""
    rng = np.random.default_rng(5)
    filters = _random_filters(rng, 6, 0.25, seen_once=(2,))
    batch = ForecastBatch([f.snapshot() for f in filters], 12)
    means, covs = batch.arrays
    assert not means.flags.writeable and not covs.flags.writeable
    for i, f in enumerate(filters):
        m, c = f.predict(12)
        if i == 2:
            np.testing.assert_array_equal(means[i], m)
            np.testing.assert_array_equal(covs[i], c)
            np.testing.assert_array_equal(batch.planning_covs[i], np.repeat(c[:1], 12, axis=0))
        else:
            np.testing.assert_allclose(means[i], m, rtol=0, atol=1e-12 * (1 + np.abs(m).max()))
            np.testing.assert_allclose(covs[i], c, rtol=0, atol=1e-12 * np.abs(c).max())
            np.testing.assert_array_equal(batch.planning_covs[i], covs[i])
    a, b, d = batch.planning_covs[..., 0, 0], batch.planning_covs[..., 0, 1], batch.planning_covs[..., 1, 1]
    np.testing.assert_allclose(batch.worst_std_m ** 2, (a + d) / 2 + np.hypot((a - d) / 2, b), rtol=1e-12)


@pytest.mark.parametrize("straight", [False, True])
def test_a_banks_rows_seen_once_stand_as_each_tracks_own_forecast(straight):
    """Rows of tracks seen once (a crowd just come into view), forecast together: each one's
    own standing forecast bit for bit, which is the textbook expression (the position's
    covariance plus I (speed std T j)^2 at step j) also bit for bit; the tracks seen twice
    among them untouched by it."""
    rng = np.random.default_rng(11)
    once = (0, 2, 3, 6)
    filters = _random_filters(rng, 8, 0.5, seen_once=once)
    snaps = [f.snapshot() for f in filters]
    rows = np.array([(*s.state, *s.cov_upper) for s in snaps])
    seen = [s.measurements_seen for s in snaps]
    batch = ForecastBatch.of_rows(rows, seen, 0.5, filters[0].settings, 12)
    if straight:
        batch = batch.straightened()
    means, covs = batch.arrays
    grow = (filters[0].settings.initial_speed_std_mps * 0.5) ** 2
    steps2 = np.arange(1, 13, dtype=float) ** 2
    for i, s in enumerate(snaps):
        m, c = s.predict(12, straight=straight)
        if i in once:
            np.testing.assert_array_equal(means[i], m)
            np.testing.assert_array_equal(covs[i], c)
            np.testing.assert_array_equal(m, np.tile(np.array(s.state[:2]), (12, 1)))
            np.testing.assert_array_equal(c, s.cov_array()[:2, :2] + (np.eye(2) * grow) * steps2[:, None, None])
        else:
            np.testing.assert_allclose(means[i], m, rtol=0, atol=1e-12 * (1 + np.abs(m).max()))
            assert not np.allclose(means[i], means[i][:1])  # forecast moving, not standing


def test_the_tracker_batches_a_crowd_and_the_check_takes_its_arrays_whole():
    rng = np.random.default_rng(8)
    n = MANY_TRACKS + 3
    filters = _random_filters(rng, n, 0.25)
    pairs = [(ObstacleMeasurement(i, (0.0, 0.0), 0.3), f) for i, f in enumerate(filters)]
    tracks = track_estimates(pairs, 12)
    batch = shared_batch(tracks)
    assert isinstance(batch, ForecastBatch) and len(batch) == n
    for t, (m, f) in zip(tracks, pairs):
        one = track_estimate(f, m.obstacle_id, m.radius_m, 12)   # track by track, as below MANY_TRACKS
        np.testing.assert_array_equal(t.state, one.state)
        np.testing.assert_allclose(t.means_m, one.means_m, rtol=0, atol=1e-12 * (1 + np.abs(one.means_m).max()))
        np.testing.assert_allclose(t.covs_m2, one.covs_m2, rtol=0, atol=1e-12 * np.abs(one.covs_m2).max())
    m, c, w = forecast_arrays(tracks)
    assert m is batch.arrays[0] and c is batch.planning_covs and w is batch.worst_std_m
    # another order (or a subset) is stacked track by track: the same numbers
    back = tracks[::-1]
    assert shared_batch(back) is None and shared_batch(tracks[1:]) is None
    m2, c2, _ = forecast_arrays(back)
    np.testing.assert_array_equal(m2, m[::-1])
    np.testing.assert_array_equal(c2, np.array([forecast_covariances(t) for t in back]))
    # below MANY_TRACKS nothing is batched
    few = track_estimates(pairs[:MANY_TRACKS - 1], 12)
    assert shared_batch(few) is None and all(t.batch_ is None for t in few)


@pytest.mark.parametrize("layout_name", ["set", "multi"])
def test_a_crowds_features_read_the_batch_as_track_by_track(layout_name):
    """The features of a crowd whose forecasts were made together take every track's
    ``pos_std_m`` from the batch in one go (``_position_stds``): the very numbers each
    track's own row gives (``_position_std``), and the features of the same tracks forecast
    one by one to rounding; a track seen once among them included."""
    from casadi_gpc.robot import RobotState
    from nn_export.runtime.features import _position_std, _position_stds, feature_values_from
    from nn_export.runtime.layouts import layout_for
    rng = np.random.default_rng(5)
    n = MANY_TRACKS + 4
    filters = _random_filters(rng, n, 0.5, seen_once=(2,))
    pairs = [(ObstacleMeasurement(i, (0.0, 0.0), 0.3), f) for i, f in enumerate(filters)]
    together = track_estimates(pairs, 12)
    assert shared_batch(together) is not None
    stds = _position_stds(together)
    assert stds == [_position_std(t) for t in together] and len(set(stds)) == n
    one_by_one = tuple(track_estimate(f, m.obstacle_id, m.radius_m, 12) for m, f in pairs)
    assert _position_stds(one_by_one) is None and _position_stds(together[:3] + one_by_one[3:]) is None
    layout = layout_for(layout_name, 12)
    robot = RobotState(0.5, -0.3, 0.4, 0.2, 0.25)
    rows = [(0.1 * j, 0.0, 0.0) for j in range(13)]
    a = feature_values_from(layout, robot, rows, 0.5, together, ())
    b = feature_values_from(layout, robot, rows, 0.5, one_by_one, ())
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    k = layout.feature_names.index("mov1_pos_std_m")
    assert a[k] > 0.0


def test_the_batch_is_cheaper_than_track_by_track_in_a_crowd():
    """The reason for the batch: 10 walkers' forecasts made together cost less than one by
    one (timed in the same run, medians; 0.5-0.6x measured, asserted below 0.85x in the best
    of three blocks of 60 alternated rounds: on a shared machine a burst of load can slow the
    numpy calls more than the float ones for whole blocks: 0.83x in two blocks, and above
    0.85x once in the full suite)."""
    import time
    rng = np.random.default_rng(2)
    filters = _random_filters(rng, 10, 0.25)
    snaps = [f.snapshot() for f in filters]

    def together():
        ForecastBatch(snaps, 12).arrays

    def one_by_one():
        for s in snaps:
            s.predict(12)

    ratios = []
    for _ in range(3):
        times = {together: [], one_by_one: []}
        for _ in range(60):
            for fn in times:
                t0 = time.perf_counter()
                fn()
                times[fn].append(time.perf_counter() - t0)
        ratios.append(np.median(times[together]) / np.median(times[one_by_one]))
    assert min(ratios) < 0.85, ratios


def test_settings_of_the_batch_are_the_banks():
    """Filters with other settings than the first are forecast with their own (one by one)."""
    rng = np.random.default_rng(3)
    filters = _random_filters(rng, 5, 0.25)
    odd = ObstacleEKF(0.25, EKFSettings(speed_noise_mps2=1.0))
    odd.step((0.0, 0.0))
    odd.step((0.1, 0.0))
    filters.append(odd)
    means, covs = ForecastBatch([f.snapshot() for f in filters], 8).arrays
    m, c = odd.predict(8)
    np.testing.assert_array_equal(means[-1], m)
    np.testing.assert_array_equal(covs[-1], c)


def test_the_compiled_forecasts_are_propagates_numbers_bit_for_bit():
    """forecast_many (compiled, casadi_gpc.estimation.ekf_floats.forecast_rows) gives each track
    exactly what the Python-float propagate gives it: the same operations in the same order."""
    from casadi_gpc.estimation.ekf_floats import propagate
    rng = np.random.default_rng(3)
    T, H = 0.5, 12
    filters = _random_filters(rng, 10, T)
    states, uppers = [f.state_.tolist() for f in filters], [upper(f.cov_.ravel().tolist()) for f in filters]
    means, covs = forecast_many(states, uppers, T, filters[0]._q(), H)
    for i, (s, u) in enumerate(zip(states, uppers)):
        m, c = [], []
        propagate(*s, u, T, filters[0]._q(), H, m, c)
        assert np.array_equal(means[i].ravel(), m) and np.array_equal(covs[i].ravel(), c)


@pytest.mark.benchmark
def test_the_compiled_forecasts_cost_a_third_of_the_python_floats_or_less():
    """Same run, interleaved: ten tracks' 12-step forecasts in one compiled call against the
    Python-float propagate track by track, medians (measured 4.5 against about 160 us quiet)."""
    import time
    from casadi_gpc.estimation.ekf_floats import propagate
    rng = np.random.default_rng(4)
    T, H = 0.5, 12
    filters = _random_filters(rng, 10, T)
    states, uppers = [f.state_.tolist() for f in filters], [upper(f.cov_.ravel().tolist()) for f in filters]
    q = filters[0]._q()
    compiled, floats = [], []
    for _ in range(200):
        t0 = time.perf_counter()
        forecast_many(states, uppers, T, q, H)
        t1 = time.perf_counter()
        for s, u in zip(states, uppers):
            propagate(*s, u, T, q, H, [], [])
        t2 = time.perf_counter()
        compiled.append(t1 - t0)
        floats.append(t2 - t1)
    assert np.median(compiled) * 3 <= np.median(floats), (np.median(compiled), np.median(floats))


def _filter_fields(f: ObstacleEKF) -> dict:
    """Everything a filter holds (its arrays made afresh from its floats)."""
    d = {k: v for k, v in vars(f).items() if k not in ("_state_a", "_cov_a", "_consts", "_last_z", "pending_z_")}
    d["_last_z"] = None if f._last_z is None else tuple(np.asarray(f._last_z, dtype=float).tolist())
    d["pending_z_"] = None if f.pending_z_ is None else tuple(np.asarray(f.pending_z_, dtype=float).tolist())
    return d


def test_filters_updated_together_are_each_filters_own_step_bit_for_bit():
    """ObstacleEKF.update_together (compiled, ekf_floats.update_rows: the step's propagation and
    ekf_floats.correct) against each filter's own step on copies: the same floats to the last bit
    for the measurements that pass the gate, and the gated ones left untouched."""
    import copy
    rng = np.random.default_rng(21)
    T = 0.5
    for trial in range(20):
        filters = _random_filters(rng, 12, T)
        for f in filters:  # a few real steps first: covariances and states as a run leaves them
            for _ in range(int(rng.integers(0, 4))):
                f.step((f._s[0] + float(rng.normal(0, 0.05)), f._s[1] + float(rng.normal(0, 0.05))))
        # near the prediction (passes), or far from it (gated: an outlier or a manoeuvre)
        zs = []
        for f in filters:
            m, _ = f.predict(1)
            far = rng.random() < 0.25
            zs.append((float(m[0, 0] + rng.normal(0, 2.0 if far else 0.03)),
                       float(m[0, 1] + rng.normal(0, 2.0 if far else 0.03))))
        alone = copy.deepcopy(filters)
        before = [_filter_fields(f) for f in filters]
        ok = ObstacleEKF.update_together(filters, zs)
        assert 0 < sum(ok) < len(ok) or trial  # both kinds, at least in the first draw
        for f, g, z, updated, b in zip(filters, alone, zs, ok, before):
            event = g.step(z)
            if updated:
                assert event == "update"
                assert _filter_fields(f) == _filter_fields(g)  # the floats themselves, bit for bit
                assert f._s == g._s and f._U == g._U
            else:
                assert event != "update" and _filter_fields(f) == b


def test_a_crowds_bank_updated_together_is_the_bank_track_by_track():
    """A bank of ten and more tracks (missed, gated, restarted, manoeuvring, new, gone) stepped
    with its initialised tracks updated together, against the same bank one track at a time:
    the same pairs in the same order, the same counters, every filter the same to the bit."""
    from unittest import mock
    from casadi_gpc.estimation import tracking
    from casadi_gpc.estimation.tracking import TrackBank
    rng = np.random.default_rng(2)
    T = 0.5
    together, alone = TrackBank(T), TrackBank(T)
    pos = {i: rng.normal(0, 4, 2) for i in range(12)}
    vel = {i: rng.normal(0, 0.4, 2) for i in range(12)}
    for k in range(40):
        moving = []
        for i in range(12):
            if (i == 11 and k < 5) or (i == 10 and 20 <= k < 23):  # late, and gone for a while
                continue
            pos[i] = pos[i] + vel[i] * T
            if i == 3 and k == 15:
                vel[i] = np.zeros(2)  # stops dead: a manoeuvre
            z = pos[i] + rng.normal(0, 0.02, 2)
            if rng.random() < 0.05:
                z = z + rng.normal(0, 3, 2)  # a glitch
            moving.append(ObstacleMeasurement(i, None if rng.random() < 0.05 else (float(z[0]), float(z[1])), 0.3))
        a = together.step(moving)
        with mock.patch.object(tracking, "UPDATED_TOGETHER", 10 ** 9):
            b = alone.step(moving)
        assert [m for m, _ in a] == [m for m, _ in b]
        assert [_filter_fields(f) for _, f in a] == [_filter_fields(f) for _, f in b]
        assert together.counters == alone.counters
    assert together.counters["outliers"] and together.counters["missed_measurements"]
    assert together.counters["manoeuvres"] + together.counters["ghosts"]


def test_the_compiled_worst_deviation_is_numpys_bit_for_bit():
    """ForecastBatch.worst_std_m (compiled, ekf_floats.worst_std_rows) against the numpy
    worst_std_m on random covariances, flat ones, degenerate and slightly indefinite ones: the
    same floats."""
    from casadi_gpc.estimation.obstacle_model import worst_std_m
    from casadi_gpc.estimation.ekf_floats import worst_std_rows
    rng = np.random.default_rng(9)
    L = rng.normal(0, 0.4, (40, 12, 2, 2))
    covs = L @ np.swapaxes(L, -1, -2)
    covs[0] = 0.0
    covs[1, :, 0, 1] = covs[1, :, 1, 0] = 0.0
    covs[2] = np.array([[1e-3, 2e-3], [2e-3, 1e-3]])  # indefinite
    covs[3] *= 1e12
    covs[4] = -covs[4]  # negative: max(., 0)
    covs = np.ascontiguousarray(covs)
    assert np.array_equal(worst_std_rows(covs), worst_std_m(covs))
    covs.flags.writeable = False
    assert np.array_equal(worst_std_rows(covs), worst_std_m(covs))
    filters = _random_filters(rng, 8, 0.5, seen_once=(3,))
    batch = ForecastBatch([f.snapshot() for f in filters], 12)
    assert np.array_equal(batch.worst_std_m, worst_std_m(batch.planning_covs))


@pytest.mark.parametrize("straight", [True, False])
def test_a_banks_forecasts_made_together_are_each_tracks_own_bit_for_bit(straight):
    """TrackBank.forecasts (the planner's: from MANY_TRACKS pairs on, the filters seen twice
    made in one compiled call) against TrackBank.forecast of each pair, with the planner's
    traced forecast and without: over 30 samples of a bank of 14 tracks (new ones seen once,
    gated measurements and their ghosts, a track gone and back), the same ids, radii, means and
    planning covariances to the bit, in the same order; below MANY_TRACKS, the same too."""
    from casadi_gpc.estimation.forecast_function import ForecastFunction
    from casadi_gpc.estimation.tracking import TrackBank
    rng = np.random.default_rng(7)
    T, H = 0.5, 12
    bank = TrackBank(T, straight=straight)
    traced = ForecastFunction(T, H)
    pos = {i: rng.normal(0, 4, 2) for i in range(14)}
    vel = {i: rng.normal(0, 0.5, 2) for i in range(14)}
    seen_once = made_together = 0
    for k in range(30):
        moving = []
        for i in range(14):
            if (i >= 12 and k < 4 + 3 * (i - 12)) or (i == 5 and 10 <= k < 13):
                continue
            pos[i] = pos[i] + vel[i] * T
            z = pos[i] + rng.normal(0, 0.02, 2)
            if rng.random() < 0.06:
                z = z + rng.normal(0, 2, 2)  # gated: a ghost waits for confirmation
            moving.append(ObstacleMeasurement(i, (float(z[0]), float(z[1])), 0.25 + 0.01 * i))
        pairs = bank.step(moving)
        for function in (traced, None):
            many = bank.forecasts(pairs, H, function)
            one = [bank.forecast(m, f, H, function) for m, f in pairs]
            assert len(many) == len(one) == len(pairs)
            for a, b in zip(many, one):
                assert (a.obstacle_id, a.radius_m) == (b.obstacle_id, b.radius_m)
                assert a.means_m.shape == b.means_m.shape == (H, 2)
                assert a.means_m.tobytes() == b.means_m.tobytes()
                assert a.covs_m2.tobytes() == b.covs_m2.tobytes()
        seen_once += sum(not f.initialised for _, f in pairs)
        made_together += sum(f.initialised for _, f in pairs) if len(pairs) >= MANY_TRACKS else 0
    assert seen_once >= 3 and made_together > 200 and bank.counters["ghosts"] > 0
    few = bank.step(moving[:MANY_TRACKS - 1])
    assert [f.means_m.tobytes() for f in bank.forecasts(few, H, traced)] == \
        [bank.forecast(m, f, H, traced).means_m.tobytes() for m, f in few]
