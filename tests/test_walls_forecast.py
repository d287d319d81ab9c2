"""The walkers' learned forecast near walls (casadi_gpc/estimation/walls_forecast.py): its
features against the prototype's walker-by-walker form (the one that made the network's training
data), the batched wall scan against one point at a time, the union it hands the
planner (the filter's forecasts untouched, one second mover per walker seen at 9 samples, the
filter's covariances), nothing added without walls, the presets and the sample times it
answers at, and a bad model file refused in one line."""
from __future__ import annotations

import math

import numpy as np
import pytest

from casadi_gpc.config import preset
from casadi_gpc.estimation.walls_forecast import (HORIZON, N_INPUTS, PAST, UNION_ID, WallsForecast,
                                                  walker_features)
from casadi_gpc.geometry import segment_rows, wall_scan, wall_scans
from casadi_gpc.types import ObstacleForecast, ObstacleMeasurement

CORRIDOR = (((-10.0, 0.0), (20.0, 0.0)), ((-10.0, 2.5), (20.0, 2.5)))


def _reference_features(meas, k, j, wall_rows, T=0.5):
    """The features of walker ``j`` at sample ``k`` written out walker by walker, as the prototype
    that made the shipped network's training data wrote them (docs/data/pedestrians/
    learned_forecast/data.py before 2026-11-30, which now calls the planner's own): an
    independent form to hold the compiled one to."""
    past = meas[k - PAST:k + 1, j]
    if k < PAST or not np.isfinite(past).all():
        return None
    d = past[-1] - past[-5]
    n = float(np.hypot(*d))
    c, s = (1.0, 0.0) if n < 0.05 else (d[0] / n, d[1] / n)
    R = np.array([[c, s], [-s, c]])
    now = past[-1]
    own = ((past[:-1] - now) @ R.T).ravel()
    others = []
    here, before = meas[k], meas[k - 1]
    for i in range(meas.shape[1]):
        if i != j and np.isfinite(here[i]).all() and np.isfinite(before[i]).all():
            rel = here[i] - now
            dist = float(np.hypot(*rel))
            if dist <= 6.0:
                others.append((dist, rel @ R.T, (here[i] - before[i]) / T @ R.T))
    others.sort(key=lambda o: o[0])
    nb = np.zeros(40)
    for q, (_, p, v) in enumerate(others[:8]):
        nb[5 * q:5 * q + 5] = (1.0, *p, *v)
    scan = wall_scan(wall_rows, float(now[0]), float(now[1]), math.atan2(s, c), 16, 4.0)
    return np.concatenate([own, nb, scan]), c, s


def _crowd(rng, walkers=14, missing=0.05):
    """Measured positions ``(PAST + 1, walkers, 2)`` of walkers in and near a corridor, some
    missing, two standing still, one pair at the same distance from a third."""
    start = np.column_stack([rng.uniform(-4, 8, walkers), rng.uniform(0.3, 2.2, walkers)])
    vel = rng.normal(0, 0.8, (walkers, 2))
    vel[:2] = 0.0  # standing: the world's frame
    meas = start[None] + vel[None] * 0.5 * np.arange(PAST + 1)[:, None, None]
    meas += rng.normal(0, 0.02, meas.shape)
    meas[-1, 3] = meas[-1, 2] + (0.5, 0.0)
    meas[-1, 4] = meas[-1, 2] + (-0.5, 0.0)  # walkers 3 and 4 equally far from walker 2
    meas[rng.uniform(size=meas.shape[:2]) < missing] = np.nan
    return meas


def test_the_features_are_the_prototypes():
    reference = _reference_features
    rng = np.random.default_rng(3)
    rows = segment_rows(CORRIDOR + (((5.0, 0.0), (5.0, 1.0)),))
    compared = differ = 0
    for trial in range(30):
        meas = _crowd(rng)
        X, cos, sin, cols = walker_features(meas, list(range(meas.shape[1])), rows)
        ref = [(j, reference(meas, PAST, j, rows)) for j in range(meas.shape[1])]
        ref = [(j, r) for j, r in ref if r is not None]
        assert cols == [j for j, _ in ref]
        assert X.shape == (len(cols), N_INPUTS)
        for (j, (x, c, s)), row, cj, sj in zip(ref, X, cos, sin):
            np.testing.assert_allclose(row, x, rtol=0, atol=1e-12)  # rotations written out, not a matmul
            # what the network reads (float32) is the same but for rounding noise about zero (the
            # frame's own direction point, 0 across the frame up to 1e-17, whose training scale is 1e-3)
            differ += int(np.sum((row.astype(np.float32) != x.astype(np.float32)) & (np.abs(x) > 1e-12)))
            assert (cj, sj) == pytest.approx((c, s), abs=1e-15)
            compared += 1
    assert compared > 200
    assert differ == 0


def test_a_walker_not_measured_at_every_sample_has_no_features():
    rng = np.random.default_rng(5)
    meas = _crowd(rng, missing=0.0)
    meas[2, 1] = np.nan
    _, _, _, cols = walker_features(meas, [0, 1, 2], segment_rows(CORRIDOR))
    assert cols == [0, 2]


def test_the_batched_scan_is_one_point_at_a_time():
    rng = np.random.default_rng(11)
    for _ in range(200):
        rows = rng.uniform(-5, 5, (rng.integers(0, 6), 4))
        xs, ys, hs = rng.uniform(-3, 3, 4), rng.uniform(-3, 3, 4), rng.uniform(-4, 4, 4)
        B = wall_scans(rows, xs, ys, np.cos(hs), np.sin(hs), 16, 4.0)
        for i in range(4):
            one = wall_scan(rows, xs[i], ys[i], math.atan2(math.sin(hs[i]), math.cos(hs[i])), 16, 4.0)
            np.testing.assert_allclose(B[i], one, rtol=0, atol=1e-12)


class _Obs:
    def __init__(self, t, moving, walls=CORRIDOR):
        self.t_s, self.moving, self.walls = t, moving, walls


def _filters(ids, H=HORIZON):
    return [ObstacleForecast(i, 0.25, np.full((H, 2), float(i)), np.tile(np.eye(2) * (0.01 + i), (H, 1, 1)))
            for i in ids]


def test_the_union_keeps_the_filters_forecasts_and_adds_one_mover_per_walker_seen_nine_times():
    wf = WallsForecast()
    counters = {}
    out = None
    for k in range(PAST + 1):
        moving = [ObstacleMeasurement(7, (1.0 + 0.6 * k * 0.5, 1.0), 0.25),
                  ObstacleMeasurement(9, (8.0 - 0.5 * k * 0.5, 1.6), 0.25)]
        if k >= 3:  # walker 11 comes into view late
            moving.append(ObstacleMeasurement(11, (3.0, 2.0), 0.25))
        own = _filters([m.obstacle_id for m in moving])
        out = wf.add(_Obs(0.5 * k, moving), own, counters)
        if k < PAST:
            assert out == own  # nobody seen at nine samples yet
    assert out[:3] == own
    extra = out[3:]
    assert [f.obstacle_id for f in extra] == [7 + UNION_ID, 9 + UNION_ID]
    for f, base in zip(extra, own):
        assert f.radius_m == base.radius_m
        assert f.means_m.shape == (HORIZON, 2) and np.isfinite(f.means_m).all()
        np.testing.assert_array_equal(f.covs_m2, base.covs_m2)
    # walker 7 walks +x at 0.6 m/s along the corridor: its learned forecast goes on ahead of it
    assert extra[0].means_m[-1, 0] > 1.0 + 0.6 * 4 + 1.0
    assert counters["walls_forecasts"] == 2


def test_nothing_is_added_without_walls():
    wf = WallsForecast()
    for k in range(PAST + 3):
        moving = [ObstacleMeasurement(7, (1.0 + 0.3 * k, 1.0), 0.25)]
        own = _filters([7])
        assert wf.add(_Obs(0.5 * k, moving, walls=()), own) is own


def test_the_presets_and_sample_times():
    assert WallsForecast.for_config(preset("paper")) is None
    assert isinstance(WallsForecast.for_config(preset("improved")), WallsForecast)
    assert WallsForecast.for_config(preset("improved").with_overrides(sample_time_s=0.25)) is None
    assert WallsForecast.for_config(preset("improved").with_overrides(horizon=8)) is None
    assert WallsForecast.for_config(preset("improved").with_overrides(walls_forecast=False)) is None


def test_a_bad_model_file_is_refused_in_one_line(tmp_path):
    bad = tmp_path / "x.onnx"
    bad.write_bytes(b"not a model")
    with pytest.raises(ValueError) as e:
        WallsForecast(bad)
    assert "x.onnx" in str(e.value) and "\n" not in str(e.value)


def test_a_new_episode_without_reset_starts_the_history_again():
    wf = WallsForecast()
    own = _filters([7])
    for k in range(PAST + 1):
        out = wf.add(_Obs(0.5 * k, [ObstacleMeasurement(7, (1.0 + 0.3 * k, 1.0), 0.25)]), own)
    assert len(out) == 2
    assert wf.add(_Obs(0.0, [ObstacleMeasurement(7, (1.0, 1.0), 0.25)]), own) == own  # time went back


def test_the_gpc_hands_its_check_the_second_forecast_in_a_building_only():
    from gpcnav.commands.common import for_run
    from gpcnav.controllers import ControllerSpec, make
    from scenarios import Suite
    from scenarios.simulator import simulate

    counts = {}
    for suite in ("corridor", "circle-crossing"):
        sc = Suite(suite, 1, 1, 5, "orca").scenario(0)
        cfg = for_run(preset("improved"), [sc])
        log = simulate(sc, make(ControllerSpec("gpc"), cfg, sc.robot), "gpc")
        counts[suite] = log.events.get("walls_forecasts", 0)
    assert counts["corridor"] > 0 and counts["circle-crossing"] == 0


def test_one_session_a_process_however_many_planners():
    assert WallsForecast().session is WallsForecast().session


def test_the_buffer_grows_for_a_crowd_and_frees_the_columns_of_walkers_long_gone():
    wf = WallsForecast()
    for k in range(3):  # 40 walkers, more than the buffer's first 16 columns
        wf.add(_Obs(0.5 * k, [ObstacleMeasurement(i, (0.2 * i, 1.0), 0.25) for i in range(40)]), [])
    assert len(wf._col) == 40 and wf._buf.shape[1] >= 40
    for k in range(3, 3 + PAST + 1):  # then only walker 0, long enough for the others to be forgotten
        wf.add(_Obs(0.5 * k, [ObstacleMeasurement(0, (0.0, 1.0), 0.25)]), [])
    assert list(wf._col) == [0] and np.isnan(np.delete(wf._buf, wf._col[0], axis=1)).all()
