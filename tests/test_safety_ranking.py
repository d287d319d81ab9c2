"""The fast forms of the check's failing path against the forms they replace (issue 34: the
decisions whose command fails the check): the best sequence's index compiled
(:mod:`casadi_gpc.safety.ranking`), a candidate's limits in plain floats, the searched grid's
rows that are manoeuvres too measured once, and the exact check's obstacles made from the
screen's arrays. Each is compared with the old form to the bit (index for index, number for
number)."""
from __future__ import annotations

import numpy as np
import pytest

from casadi_gpc.robot import RobotParams
from casadi_gpc.safety import SafetyFilter
from casadi_gpc.safety.ranking import TIE_M, best_unsafe_index, pick_index, within_limits_floats
from casadi_gpc.types import ObstacleForecast, StaticObstacle

ROBOT = RobotParams()
H, T = 12, 0.5


# The numpy forms the compiled ones replaced (the references; the shipped code no longer has them)

def _best_numpy(among: np.ndarray, cmin: np.ndarray) -> int:
    """The first index of ``among`` whose smallest clearance is the largest there (ties within TIE_M)."""
    return int(np.argmax(among & (cmin >= cmin[among].max() - TIE_M)))


def best_unsafe_index_numpy(cmin, kept, contact, fixed, drives, rdrives, commit: int) -> int:
    """:func:`best_unsafe_index` as numpy took it (the reference; with the uncertain drive-in's
    key, ``rdrives``, after the contact's)."""
    driven = np.minimum(drives, commit)
    first = driven == driven.max()
    first &= contact == contact[first].max()
    rdriven = np.minimum(rdrives, commit)
    first &= rdriven == rdriven[first].max()
    first &= fixed == fixed[first].max()
    return _best_numpy(first & (kept == kept[first].max()), cmin)


def pick_index_numpy(cmin, kept, contact, fixed, drives, rdrives, n_chords: int, commit: int) -> int:
    """:func:`pick_index` as numpy took it (the reference)."""
    if len(cmin) <= 1:
        return 0
    safe = kept == n_chords
    return _best_numpy(safe, cmin) if safe.any() else best_unsafe_index_numpy(cmin, kept, contact, fixed, drives,
                                                                              rdrives, commit)


def within_limits_numpy(robot, sample_time_s, v0, wheels: np.ndarray) -> bool:
    """``TrajectoryCheck.within_limits`` as it was: whether the (H, 2) sequence keeps the
    speed and rate limits."""
    dv, vmax = robot.max_step_change_mps(sample_time_s), robot.max_wheel_speed_mps
    tol = 1e-9
    if np.abs(wheels).max() > vmax + tol or np.abs(wheels[0] - v0).max() > dv + tol:
        return False
    return len(wheels) < 2 or bool(np.abs(wheels[1:] - wheels[:-1]).max() <= dv + tol)


def _filter() -> SafetyFilter:
    return SafetyFilter(ROBOT, T, H, search=True)


def _crowd(rng, n: int, spread: float = 3.0):
    """``n`` walkers near the robot (random walks with growing covariances) and two static discs."""
    out = []
    for i in range(n):
        start, vel = rng.uniform(-spread, spread, 2), rng.uniform(-0.8, 0.8, 2)
        k = np.arange(1, H + 1)[:, None]
        means = start + k * T * vel + rng.normal(0.0, 0.02, (H, 2)).cumsum(axis=0)
        a = rng.uniform(1e-4, 0.05) * np.arange(1, H + 1)
        b = rng.uniform(-0.5, 0.5) * a
        covs = np.stack([np.stack([a, b], -1), np.stack([b, a * rng.uniform(0.5, 2.0)], -1)], 1)
        out.append(ObstacleForecast(i, rng.uniform(0.2, 0.4), means, covs))
    statics = (StaticObstacle((rng.uniform(-4, 4), rng.uniform(-4, 4)), 0.3),
               StaticObstacle((rng.uniform(-4, 4), rng.uniform(-4, 4)), 0.5))
    return out, statics


def _random_found(rng, M: int, N: int, commit: int):
    cmin = rng.choice([-0.3, -0.1, 0.0, 0.02, 0.1, 0.1 + 5e-10, 0.3], M) + rng.choice([0.0, 1e-12], M)
    pick = lambda: rng.choice([0, 3, 8, 12, 20, N], M).astype(np.int64)  # noqa: E731 (ties on purpose)
    return cmin, pick(), pick(), pick(), pick(), pick()


def test_pick_index_is_the_numpy_forms():
    rng = np.random.default_rng(34)
    N, commit = 48, 12
    for trial in range(4000):
        M = int(rng.integers(1, 50))
        found = _random_found(rng, M, N, commit)
        if trial % 7 == 0:
            found[0][rng.integers(0, M)] = np.inf
        if trial % 11 == 0:
            found[0][rng.integers(0, M)] = np.nan  # numpy's max is NaN: index 0
        assert pick_index(*found, N, commit) == pick_index_numpy(*found, N, commit)
        if M > 1:
            assert best_unsafe_index(*found, commit) == best_unsafe_index_numpy(*found, commit)


def test_within_limits_floats_is_the_numpy_form():
    f = _filter()
    rng = np.random.default_rng(3)
    dv, vmax = ROBOT.max_step_change_mps(T), ROBOT.max_wheel_speed_mps
    for _ in range(3000):
        v0 = rng.uniform(-vmax, vmax, 2)
        steps = rng.choice([-dv, -dv - 1e-9, dv + 2e-9, dv, 0.0, 0.3 * dv], (H, 2))
        w = np.clip(v0 + steps.cumsum(axis=0), -vmax - rng.choice([0.0, 1e-9, 1e-8]), vmax + 1e-9)
        for seq in (w, w[:1]):
            assert within_limits_floats(float(v0[0]), float(v0[1]), seq.tolist(), f._dv_tol, f._vmax_tol) == \
                within_limits_numpy(ROBOT, T, v0, seq)


def test_grid_rows_that_are_manoeuvres_are_the_same_sequences():
    f = _filter()
    assert len(f._grid_own) == len(f._search_targets) - 5  # brake, slow left and right, reverse, dash
    rng = np.random.default_rng(5)
    for _ in range(500):
        cmd = rng.uniform(-1.0, 1.0, 2) * ROBOT.max_wheel_speed_mps
        if rng.random() < 0.2:
            cmd = np.array([0.0, -0.0])
        full = np.concatenate([f._escapes(cmd, True), f._escapes(cmd)])
        own = np.concatenate([f._escapes(cmd, True, own_only=True), f._escapes(cmd)])
        assert own[f._set_order].tobytes() == full.tobytes()
        W = np.concatenate([f._searched(cmd, H), f.manoeuvres(cmd)[1]])
        assert W[f._set_rows][f._set_order].tobytes() == W.tobytes()


def _old_way_out(f, state, cmd, obstacles):
    """``_way_out_after`` as it was: the whole grid rolled out and measured."""
    man = f.clearances(state, f._escapes(cmd), obstacles)
    way_out = f._pick(man, obstacles, f._then_names)
    if not way_out.safe:
        grid = f.clearances(state, f._escapes(cmd, True), obstacles)
        searched = f._pick(tuple(np.concatenate(ab) for ab in zip(grid, man)), obstacles, f._then_search_names)
        if f._better(searched, way_out):
            way_out = searched
    return way_out


def _old_search(f, state, obstacles, wish):
    """``search`` as it was: every row of the set rolled out and measured."""
    v0 = state[3:5]
    W = np.concatenate([f._searched(v0, H), f.manoeuvres(v0)[1]])
    found = f.clearances(state, W, obstacles)
    safe = found[4] == H * f.substeps
    if safe.any():
        w = np.broadcast_to(np.asarray(wish, float), (H, 2))
        cost = (((W - w) ** 2).sum(axis=2) * f._search_weights).sum(axis=1)
        i = int(np.argmin(np.where(safe, cost, np.inf)))
    else:
        i = best_unsafe_index_numpy(found[0], found[4], found[5], found[6], found[7], found[8], f._commit_chords)
    return f._search_names[i], W[i], f._verdict(found, i, obstacles, f._search_names[i])


@pytest.mark.parametrize("n", [6, 10, 16])
def test_way_out_and_search_are_the_old_forms(n):
    f = _filter()
    rng = np.random.default_rng(n)
    vmax = ROBOT.max_wheel_speed_mps
    unsafe = 0
    for _ in range(40):
        forecasts, statics = _crowd(rng, n, spread=rng.choice([1.5, 3.0, 6.0]))
        state = np.array([*rng.uniform(-0.5, 0.5, 2), rng.uniform(-3, 3), *rng.uniform(-vmax, vmax, 2)])
        cmd = np.clip(state[3:5] + rng.uniform(-0.2, 0.2, 2), -vmax, vmax)
        obstacles = f.obstacle_tracks(forecasts, statics)
        new = f._way_out_after(state, cmd, obstacles)
        assert new == _old_way_out(f, state, cmd, f.obstacle_tracks(forecasts, statics))
        unsafe += not new.safe
        name, w, chk = f.search(state, obstacles, cmd)
        oname, ow, ochk = _old_search(f, state, obstacles, cmd)
        assert (name, w.tobytes(), chk) == (oname, ow.tobytes(), ochk)
    assert unsafe  # some of them went through the grid


def test_screened_obstacles_are_obstacle_tracks():
    f = _filter()
    rng = np.random.default_rng(9)
    for n in (4, 10, 20):
        forecasts, statics = _crowd(rng, n)
        f._screen_memo = (forecasts, statics, f._quick_obstacle_arrays(forecasts, statics))
        a, b = f._screened_obstacles(forecasts, statics, None), f.obstacle_tracks(forecasts, statics)
        for name in ("q", "touch", "radii", "walls"):
            x, y = getattr(a, name), getattr(b, name)
            assert x.shape == y.shape and x.dtype == y.dtype and x.tobytes() == y.tobytes(), name
        assert a.moving == b.moving and a.statics == b.statics
        assert f._screened_obstacles(list(forecasts), statics, None) is None  # other obstacles: none
    f._screen_memo = None
