"""Observations that come more than one sample apart (a dropped sensor frame, a decision loop
that overran): the obstacle filters and the reference clock step the samples missed
(casadi_gpc.types.samples_since, casadi_gpc.estimation.tracking.missed_steps), counted."""
import math

import pytest

from casadi_gpc import ReferencePath, Segment
from casadi_gpc.estimation.track_rows import RowBank
from casadi_gpc.estimation.tracking import TrackBank
from casadi_gpc.progress import ReferenceClock
from casadi_gpc.types import ObstacleMeasurement, samples_since

T = 0.5


def test_samples_since_rounds_the_gap_to_whole_samples():
    assert samples_since(None, 7.3, T) == 1
    assert [samples_since(1.0, 1.0 + g, T) for g in (0.25, 0.5, 0.74, 0.76, 1.0, 2.6)] == [1, 1, 1, 2, 2, 5]
    for t in (1.0, 1.2, 0.0, -3.0, math.nan):
        with pytest.raises(ValueError, match="less than half the sample time"):
            samples_since(1.0, t, T)


def _walkers(t: float, missing: bool = False) -> list:
    """Six walkers at 1 m/s along x (one at 0.6 m/s across), their positions at ``t``."""
    out = [ObstacleMeasurement(k, (1.0 * t + k, float(k)), 0.3) for k in range(5)]
    out.append(ObstacleMeasurement(9, (3.0, -2.0 + 0.6 * t), 0.3))
    return [ObstacleMeasurement(m.obstacle_id, None, m.radius_m) for m in out] if missing else out


TIMES = [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5]
DROPPED = {3.0, 4.0, 4.5}  # one frame, then two in a row


@pytest.mark.parametrize("bank_class", [TrackBank, RowBank])
def test_a_dropped_frame_is_a_sample_with_every_measurement_missing(bank_class):
    """The exact answer: a bank told the time, with the dropped frames left out, ends where a bank
    given those frames with every position missing ends, to the bit, and counts the same."""
    told, missing = bank_class(T), bank_class(T)
    for t in TIMES:
        if t not in DROPPED:
            told.step(_walkers(t), t)
        missing.step(_walkers(t, missing=t in DROPPED))
    for k in (0, 3, 9):
        assert told.filters[k]._s == missing.filters[k]._s and told.filters[k]._U == missing.filters[k]._U
    assert told.counters["missed_samples"] == 3 and missing.counters["missed_samples"] == 0
    assert {k: v for k, v in told.counters.items() if k != "missed_samples"} == \
        {k: v for k, v in missing.counters.items() if k != "missed_samples"}
    assert told.counters["outliers"] == 0 and told.counters["missed_measurements"] == 3 * 6


def test_without_the_time_a_dropped_frame_is_an_outlier_and_a_lag():
    """What the banks did before (and still do for a caller that gives no time): the walker seen
    0.5 m on after the gap is gated out, the estimate left 0.5 m behind with a ghost."""
    bank = TrackBank(T)
    for t in TIMES[:6] + [3.5]:
        bank.step(_walkers(t))
    assert bank.counters["outliers"] >= 5 and bank.counters["ghosts"] >= 5
    assert bank.filters[0]._s[0] == pytest.approx(3.0, abs=0.05)  # the walker is at 3.5
    told = TrackBank(T)
    for t in TIMES[:6] + [3.5]:
        told.step(_walkers(t), t)
    assert told.counters["outliers"] == 0 and told.filters[0]._s[0] == pytest.approx(3.5, abs=1e-6)


@pytest.mark.parametrize("bank_class", [TrackBank, RowBank])
def test_a_time_not_a_sample_on_is_refused_and_changes_nothing(bank_class):
    bank = bank_class(T)
    for t in TIMES[:4]:
        bank.step(_walkers(t), t)
    before = (bank.filters[0]._s, dict(bank.counters))
    for t in (1.5, 1.6, 0.0):
        with pytest.raises(ValueError, match=r"t=%s s came" % t):
            bank.step(_walkers(t), t)
    assert (bank.filters[0]._s, bank.counters) == before
    bank.step(_walkers(2.0), 2.0)
    assert bank.counters["missed_samples"] == 0


def test_the_reference_point_advances_over_the_samples_missed():
    """A robot on schedule (at the paper's point at every sample): the clock that waits for it
    keeps its point on schedule across a gap, where one step a call left it a step behind."""
    path = ReferencePath((0.0, 0.0), 0.0, (Segment.line(10.0),), 0.4)
    every, gapped = ReferenceClock(T, max_lead_m=0.6), ReferenceClock(T, max_lead_m=0.6)
    for t in TIMES:
        xy = (0.4 * t, 0.0)
        every.update(path, t, xy)
        if t not in DROPPED:
            gapped.update(path, t, xy)
    assert gapped.s_m == pytest.approx(every.s_m, abs=1e-12) and every.s_m == pytest.approx(0.4 * 5.5)
    with pytest.raises(ValueError, match="less than half the sample time"):
        gapped.update(path, 5.5, (2.2, 0.0))


def test_the_controllers_count_the_samples_missed_and_refuse_a_repeated_time():
    """The deployed policy behind its check, and the GPC: a frame dropped mid-run is counted, a
    decision asked twice at one instant refused in one line; the walker crossing ahead is tracked
    without an outlier."""
    import numpy as np

    from casadi_gpc import GPCController, preset
    from casadi_gpc.robot import RobotState
    from casadi_gpc.safety import Shield
    from casadi_gpc.types import Observation
    from conftest import REPO
    from nn_export import OnnxPolicy
    from scenarios import load_scenario

    scene = load_scenario(REPO / "scenarios" / "paper" / "fig7_2_crossing.toml")
    ref = scene.reference

    def obs(t):
        x, y, h = ref.pose_at_time(t)
        walker = ObstacleMeasurement(1, (x + 3.0, y - 2.0 + 0.8 * t), 0.3)
        return Observation(t, RobotState(x, y, h, 0.3, 0.3), ref, (walker,), (), ())

    for controller in (Shield(OnnxPolicy(preset="improved"), scene.robot), GPCController(preset("improved"))):
        for t in (0.0, 0.5, 1.0, 2.0, 2.5):  # the frame at 1.5 s dropped
            d = controller.decide(obs(t))
            assert np.isfinite([d.v_right_mps, d.v_left_mps]).all()
        counters = controller.counters
        assert counters["missed_samples"] == 1 and counters["outliers"] == 0, counters
        with pytest.raises(ValueError, match="t=2.5 s came 0 s after"):
            controller.decide(obs(2.5))
        controller.reset()
        controller.decide(obs(0.0))  # a new episode after reset()


@pytest.mark.parametrize("bank_class", [TrackBank, RowBank])
def test_a_gap_longer_than_a_minute_starts_every_track_afresh(bank_class):
    """A pause (or a clock that jumped) of more than STALE_GAP_S: the banks forget their tracks
    instead of stepping every missed sample (a gap of 1e6 s was 2e6 steps a filter, 6 to 11 s for
    one decision; a day, 172 800 samples, would be seconds a track), and every obstacle's next
    measurement starts a new track, counted in ``dropped_tracks``. A gap of up to a minute is
    still stepped sample by sample."""
    from casadi_gpc.estimation.tracking import STALE_GAP_S
    import time
    for gap, stepped in ((STALE_GAP_S - 1.0, True), (STALE_GAP_S + 1.0, False), (1e9, False)):
        bank = bank_class(T)
        for t in TIMES[:4]:
            bank.step(_walkers(t), t)
        t_after = TIMES[3] + gap
        t0 = time.perf_counter()
        bank.step(_walkers(t_after), t_after)
        assert time.perf_counter() - t0 < 0.5
        assert bank.counters["missed_samples"] == round(gap / T) - 1
        assert bank.counters.get("dropped_tracks", 0) == (0 if stepped else 6)
        assert (bank.filters[0].measurements_seen_ >= 2) is stepped  # a new track has seen one position
        assert bank.counters["missed_measurements"] == ((round(gap / T) - 1) * 6 if stepped else 0)
