"""Path comparison metrics (scenarios.metrics): known answers on hand-made paths."""
import numpy as np
import pytest

from scenarios.metrics import path_deviation_m, same_instant_deviation_m


def test_path_deviation_known_answers():
    a = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    # b runs parallel 0.1 m away, then ends 0.3 m off a's end
    b = np.array([[0.0, 0.1], [0.5, 0.1], [2.0, 0.3]])
    assert path_deviation_m(a, b) == pytest.approx(0.3, abs=1e-12)
    assert path_deviation_m(b, a) == pytest.approx(0.3, abs=1e-12)
    # same instants: (1, 0) against (0.5, 0.1)
    assert same_instant_deviation_m(a, b) == pytest.approx(np.hypot(0.5, 0.1), abs=1e-12)


def test_path_deviation_ignores_timing_but_not_shape():
    s = np.linspace(0.0, 10.0, 41)
    curve = np.column_stack([s, np.sin(s)])
    slow = np.column_stack([s[::2], np.sin(s[::2])])  # the same curve, sampled half as often
    # only the chord error of the coarser polyline: h^2/8 max|y''| = 0.5^2/8 = 0.031 m
    assert path_deviation_m(curve, slow) == pytest.approx(0.5 ** 2 / 8, abs=2e-3)
    assert same_instant_deviation_m(curve, slow) > 1.0  # the slower robot lags behind
    # a swerve to the other side is caught: mirror the curve
    other = np.column_stack([s, -np.sin(s)])
    assert path_deviation_m(curve, other) > 1.5  # the peaks are 2 m apart vertically


def test_path_deviation_is_symmetric_for_a_short_path():
    """A run that stops early is far from the end of the other path (both directions count)."""
    a = np.column_stack([np.linspace(0, 10, 11), np.zeros(11)])
    b = a[:4]
    assert path_deviation_m(a, b) == pytest.approx(7.0)
    assert path_deviation_m(b, a) == pytest.approx(7.0)


def test_clopper_pearson_upper_bound_against_known_values():
    from scenarios.metrics import clopper_pearson_upper
    assert clopper_pearson_upper(0, 200) == pytest.approx(1 - 0.05 ** (1 / 200), abs=1e-12)  # 1.49 %
    assert round(100 * clopper_pearson_upper(0, 200), 2) == 1.49
    # R: binom.test(1, 200, alternative = "less")$conf.int[2] = 0.02350; binom.test(3, 10, ...) = 0.6066
    assert clopper_pearson_upper(1, 200) == pytest.approx(0.023498, abs=1e-6)
    assert clopper_pearson_upper(3, 10) == pytest.approx(0.606624, abs=1e-6)
    assert clopper_pearson_upper(10, 10) == 1.0
    with pytest.raises(ValueError):
        clopper_pearson_upper(11, 10)


def test_path_length_of_exact_arcs():
    from scenarios.metrics import path_length_m
    # 0.4 m/s for 3 intervals of 0.5 s, then 0.2 m/s backwards (turning) for 2: 0.6 + 0.2 m
    states = [[0, 0, 0, 0, 0], [0, 0, 0, 0.4, 0.4], [0, 0, 0, 0.4, 0.4], [0, 0, 0, 0.4, 0.4],
              [0, 0, 0, -0.1, -0.3], [0, 0, 0, -0.1, -0.3]]
    assert path_length_m(states, 0.5) == pytest.approx(0.8, abs=1e-12)


def test_same_instant_deviation_pairs_the_records_by_their_times():
    """A collided run's last record is its contact (1.3 s), not a sample: paired by place it was
    compared with the other run's sample at 1.5 s (found by an audit)."""
    t_g, t_n = [0.0, 0.5, 1.0, 1.5, 2.0], [0.0, 0.5, 1.0, 1.3]
    gpc = np.array([[0.0, 0.0], [0.2, 0.0], [0.4, 0.0], [0.6, 0.0], [0.8, 0.0]])
    nn = np.array([[0.0, 0.0], [0.2, 0.1], [0.4, 0.2], [0.52, 0.26]])
    assert same_instant_deviation_m(nn, gpc, t_n, t_g) == pytest.approx(0.2, abs=1e-12)  # at 1.0 s
    assert same_instant_deviation_m(nn, gpc) == pytest.approx(np.hypot(0.08, 0.26), abs=1e-12)  # the old pairing
