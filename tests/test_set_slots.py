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


def test_where_the_compiled_slots_do_not_answer():
    """More tracks than slots (the nearest are sorted out), tracks without a shared batch,
    another layout: CrowdSlots.make says None, and the policy takes the plain-float features."""
    rng = np.random.default_rng(1)
    assert CrowdSlots.make(LAYOUT, _crowd(rng, 13), ()) is None
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
        tracks = _crowd(rng, int(rng.integers(6, 13)), seen_once=(1,), spread=6.0)
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
