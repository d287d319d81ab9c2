"""The set layout's compiled obstacle slots (nn_export/runtime/set_slots.py) against the one
definition of the features (features.feature_values_from), value for value, and the roll-out
that reads them against the roll-out through the plain-float features."""
from __future__ import annotations

import math

import numpy as np
import pytest

from casadi_gpc.estimation.ekf import ObstacleEKF
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState
from casadi_gpc.types import ObstacleMeasurement, StaticObstacle
from nn_export.runtime.features import feature_values_from
from nn_export.runtime.layouts import layout_for
from nn_export.runtime.rollout import roll_out
from nn_export.runtime.set_slots import CrowdSlots
from nn_export.runtime.situation import reference_rows, track_estimates

H, T = 12, 0.5
LAYOUT = layout_for("set", H)


def _crowd(rng, n: int, seen_once=(), spread: float = 9.0):
    """``n`` track estimates of one bank's step (a shared forecast batch), some seen once."""
    pairs = []
    for i in range(n):
        ekf = ObstacleEKF(T)
        p = rng.uniform(-spread, spread, 2)
        v = rng.normal(0, 0.4, 2)
        for k in range(1 if i in seen_once else int(rng.integers(2, 6))):
            z = p + v * T * k + rng.normal(0, 0.02, 2)
            ekf.step((float(z[0]), float(z[1])))
        pairs.append((ObstacleMeasurement(i, None, float(rng.uniform(0.2, 0.4))), ekf))
    return track_estimates(pairs, H)


def _reference(rng):
    path = ReferencePath(tuple(rng.normal(0, 1, 2).tolist()), float(rng.uniform(-3, 3)),
                         (Segment.line(float(rng.uniform(0.5, 4))), Segment.arc(float(rng.uniform(0.3, 3)),
                                                                               float(rng.uniform(-2, 2))),
                          Segment.line(20.0)), 0.4)
    return path, float(rng.uniform(0, 4))


def _values(slots, robot, rows, report=None):
    return slots.values(robot.x_m, robot.y_m, robot.heading_rad, robot.v_right_mps, robot.v_left_mps, rows, T, report)


@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_slots_are_the_features_value_for_value(seed):
    """Random crowds of 6 to 12 tracks (some seen once, some beyond the 12 m range) and 0 to 6
    static discs, robots anywhere, desired poses on lines and arcs: every feature value and the
    report equal to the last bit."""
    rng = np.random.default_rng(seed)
    for _ in range(25):
        tracks = _crowd(rng, int(rng.integers(6, 13)), seen_once=(0, 3), spread=float(rng.uniform(3, 16)))
        statics = tuple(StaticObstacle((float(a), float(b)), float(r)) for a, b, r in
                        zip(rng.uniform(-14, 14, 6), rng.uniform(-14, 14, 6), rng.uniform(0.1, 0.5, 6)))
        statics = statics[:int(rng.integers(0, 7))]
        robot = RobotState(*rng.uniform(-3, 3, 2), float(rng.uniform(-4, 4)), *rng.uniform(-0.8, 0.8, 2))
        path, s0 = _reference(rng)
        rows = reference_rows(path, s0, T, H)
        slots = CrowdSlots.make(LAYOUT, tracks, statics)
        assert slots is not None
        ra, rb = {}, {}
        a = _values(slots, robot, rows, ra)
        b = feature_values_from(LAYOUT, robot, rows, T, tracks, statics, rb)
        assert a == b and ra == rb
        assert [type(v) for v in a[2:]] == [float] * (len(a) - 2)


@pytest.mark.parametrize("seed", range(4))
def test_in_a_crowd_larger_than_the_slots_the_nearest_fill_them_as_the_features_sort_them(seed):
    """More tracks than the 12 moving slots, or more static discs than the 6 static ones (13 to
    45 tracks, as in the UCY students recordings; 0 to 10 discs): the compiled slots sort them
    nearest first as feature_values_from does (by the least distance over the track's place now
    and its forecast; both kinds sorted when either overflows), at the decision (step 0) and
    moved along the forecasts (steps 1 to H - 1, the roll-out's): every value and the report,
    dropped obstacles counted, equal to the last bit."""
    from nn_export.runtime.rollout import _Ahead
    rng = np.random.default_rng(100 + seed)
    dropped = 0  # cases where obstacles in range were left out (the sort decides which)
    for _ in range(12):
        n = int(rng.choice([int(rng.integers(13, 46)), int(rng.integers(6, 13))]))
        tracks = _crowd(rng, n, seen_once=(0, 5), spread=float(rng.uniform(4, 16)))
        k = int(rng.integers(0, 11)) if n > LAYOUT.k_moving else int(rng.integers(LAYOUT.k_static + 1, 11))
        statics = tuple(StaticObstacle((float(a), float(b)), float(r)) for a, b, r in  # one kind overflows at least
                        zip(rng.uniform(-14, 14, k), rng.uniform(-14, 14, k), rng.uniform(0.1, 0.5, k)))
        robot = RobotState(*rng.uniform(-3, 3, 2), float(rng.uniform(-4, 4)), *rng.uniform(-0.8, 0.8, 2))
        path, s0 = _reference(rng)
        rows = reference_rows(path, s0, T, H)
        slots = CrowdSlots.make(LAYOUT, tracks, statics)
        assert slots is not None and slots.ordered
        ra, rb = {}, {}
        assert _values(slots, robot, rows, ra) == feature_values_from(LAYOUT, robot, rows, T, tracks, statics, rb)
        assert ra == rb
        dropped += bool(ra.get("dropped_moving") or ra.get("dropped_static"))
        paths = [(t, t.means_m.tolist()) for t in tracks]
        for j in range(1, H):
            ahead = [_Ahead(t, m[j - 1], j) for t, m in paths]
            x, y, th = rng.uniform(-3, 3), rng.uniform(-3, 3), rng.uniform(-4, 4)
            a = slots.values(x, y, th, 0.2, 0.3, rows, T, None, j)
            b = feature_values_from(LAYOUT, RobotState(x, y, th, 0.2, 0.3), rows, T, ahead, statics)
            assert a == b
    assert dropped >= 3


def test_where_the_compiled_slots_do_not_answer():
    """Tracks without a shared batch, another layout: CrowdSlots.make says None, and the policy
    takes the plain-float features. More tracks than slots are sorted (the test above)."""
    rng = np.random.default_rng(1)
    assert CrowdSlots.make(LAYOUT, _crowd(rng, 13), ()).ordered
    assert not CrowdSlots.make(LAYOUT, _crowd(rng, 12), ()).ordered
    few = _crowd(rng, 3)  # below MANY_TRACKS: each track its own forecast, no batch
    assert CrowdSlots.make(LAYOUT, few, ()) is None
    assert CrowdSlots.make(layout_for("multi", H), _crowd(rng, 8), ()) is None
    crowd = _crowd(rng, 8)
    assert CrowdSlots.make(LAYOUT, crowd[1:], ()) is None  # rows of a batch, not the batch in order
    assert CrowdSlots.make(LAYOUT, (), ()) is not None


@pytest.mark.parametrize("seed", range(3))
def test_the_roll_out_with_the_compiled_slots_is_the_plain_float_roll_out(seed):
    """roll_out with the decision's CrowdSlots against roll_out through feature_values_from,
    the same answering function (a fixed smooth function of the features standing in for the
    network): the same plan and poses to the last bit, and the same inputs at every step."""
    rng = np.random.default_rng(10 + seed)
    w = rng.normal(0, 0.05, LAYOUT.size)
    for _ in range(10):
        tracks = _crowd(rng, int(rng.integers(6, 30)), seen_once=(1,), spread=6.0)  # beyond the 12 slots too
        statics = (StaticObstacle((float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5))), 0.3),)
        robot = RobotState(*rng.uniform(-2, 2, 2), float(rng.uniform(-4, 4)), *rng.uniform(-0.5, 0.5, 2))
        path, s0 = _reference(rng)
        rows = reference_rows(path, s0, T, 2 * H - 1)
        seen = {True: [], False: []}

        def answer(values, key):
            seen[key].append(values)
            u = float(np.tanh(np.dot(w, values)))
            return 0.3 + 0.2 * u, 0.3 - 0.2 * math.sin(u)

        cmd = (0.31, 0.27)
        slots = CrowdSlots.make(LAYOUT, tracks, statics)
        a = roll_out(LAYOUT, lambda v: answer(v, True), robot, cmd, tracks, statics, rows, T, RobotParams(), slots)
        b = roll_out(LAYOUT, lambda v: answer(v, False), robot, cmd, tracks, statics, rows, T, RobotParams())
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
        assert seen[True] == seen[False] and len(seen[True]) == H - 1


@pytest.mark.parametrize("suite,movers,steps", [("circle-crossing", 20, 28), ("corridor", 16, 28)])
def test_the_deployed_policy_in_a_crowd_larger_than_its_slots_decides_as_with_the_plain_features(
        monkeypatch, suite, movers, steps):
    """``--controller nn`` among 20 walkers, and among 16 in the corridor (the walls network, with
    its wall scan): more than the networks' 12 moving slots. The decision's features and its
    roll-outs from the compiled slots, closed loop, against the same run with the compiled slots
    switched off (every feature in plain floats): the same commands, reasons and feature report
    at every decision, and the compiled slots did answer."""
    from dataclasses import replace

    import nn_export.runtime.policy as policy_module
    from casadi_gpc.config import preset
    from gpcnav.controllers import ControllerSpec, make
    from scenarios import Suite
    from scenarios.simulator import simulate
    cfg = preset("improved")
    sc = replace(Suite(suite, 1, 2, movers, "orca").scenario(0), duration_s=14.0)

    def run():
        pol = make(ControllerSpec("nn"), cfg, sc.robot)
        log = simulate(sc, pol, "nn")
        return [(d.v_right_mps, d.v_left_mps, d.reason) for d in log.decisions], pol.policy

    made = []
    real = CrowdSlots.make

    def counted(*a, **k):
        out = real(*a, **k)
        made.append(out is not None and out.ordered)
        return out

    monkeypatch.setattr(policy_module.CrowdSlots, "make", staticmethod(counted))
    compiled, pol_a = run()
    assert sum(made) >= 5  # the crowd was larger than the slots, and the sorted slots answered
    monkeypatch.setattr(policy_module.CrowdSlots, "make", staticmethod(lambda *a, **k: None))
    plain, pol_b = run()
    assert compiled == plain and len(compiled) == steps
    assert pol_a.counters["feature_report"] == pol_b.counters["feature_report"]
    assert pol_a.counters["feature_report"].get("dropped_moving", 0) > 0


@pytest.mark.parametrize("seed", range(3))
def test_the_compiled_slots_of_the_walls_layout_add_its_scan_as_the_features_do(seed):
    """The walls network's layout (set-walls: the slots, then the reference, then the wall
    scan): crowds within and beyond the slots, with and without wall segments, at the decision
    and along the roll-out's steps; every value equal to feature_values_from's with the same
    wall rows, and the roll-out through the compiled slots the plain-float roll-out."""
    from nn_export.runtime.rollout import _Ahead
    walls_layout = layout_for("set-walls", H)
    rng = np.random.default_rng(200 + seed)
    w = rng.normal(0, 0.05, walls_layout.size)
    for case in range(10):
        tracks = _crowd(rng, int(rng.integers(6, 30)), seen_once=(2,), spread=float(rng.uniform(3, 10)))
        statics = tuple(StaticObstacle((float(a), float(b)), 0.3) for a, b in rng.uniform(-6, 6, (int(rng.integers(0, 8)), 2)))
        k = int(rng.integers(0, 6)) if case % 3 else 0
        rows_w = np.column_stack([rng.uniform(-6, 6, (k, 2)), rng.uniform(-6, 6, (k, 2))]) if k else np.zeros((0, 4))
        slots = CrowdSlots.make(walls_layout, tracks, statics, rows_w)
        assert slots is not None
        robot = RobotState(*rng.uniform(-3, 3, 2), float(rng.uniform(-4, 4)), *rng.uniform(-0.8, 0.8, 2))
        path, s0 = _reference(rng)
        rows = reference_rows(path, s0, T, 2 * H - 1)
        ra, rb = {}, {}
        a = slots.values(robot.x_m, robot.y_m, robot.heading_rad, robot.v_right_mps, robot.v_left_mps, rows, T, ra)
        assert a == feature_values_from(walls_layout, robot, rows, T, tracks, statics, rb, rows_w) and ra == rb
        assert len(a) == walls_layout.size
        paths = [(t, t.means_m.tolist()) for t in tracks]
        j = int(rng.integers(1, H))
        ahead = [_Ahead(t, m[j - 1], j) for t, m in paths]
        assert slots.values(0.3, -0.2, 1.1, 0.2, 0.1, rows, T, None, j) == feature_values_from(
            walls_layout, RobotState(0.3, -0.2, 1.1, 0.2, 0.1), rows, T, ahead, statics, None, rows_w)

        def answer(values):
            u = float(np.tanh(np.dot(w, values)))
            return 0.3 + 0.2 * u, 0.3 - 0.2 * math.sin(u)

        one = roll_out(walls_layout, answer, robot, (0.31, 0.27), tracks, statics, rows, T, RobotParams(), rows_w, slots)
        two = roll_out(walls_layout, answer, robot, (0.31, 0.27), tracks, statics, rows, T, RobotParams(), rows_w)
        assert np.array_equal(one[0], two[0]) and np.array_equal(one[1], two[1])
