"""Known answers for reference paths of line and arc segments (casadi_gpc.reference)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from casadi_gpc.reference import ReferencePath, Segment, _project_on_line


def line_arc(angle_deg: float, radius: float = 3.0, line: float = 12.0, speed: float = 0.4) -> ReferencePath:
    return ReferencePath((0.0, 0.0), 0.0, (Segment.line(line), Segment.arc(radius, math.radians(angle_deg))), speed)


def test_segment_constructors():
    assert Segment.line(4.0) == Segment(4.0, 0.0)
    left = Segment.arc(2.0, math.pi / 2)
    assert left.length_m == pytest.approx(math.pi)
    assert left.curvature_1pm == pytest.approx(0.5)
    right = Segment.arc(2.0, -math.pi / 2)
    assert right.length_m == pytest.approx(math.pi)
    assert right.curvature_1pm == pytest.approx(-0.5)


@pytest.mark.parametrize("sign", [1, -1])
def test_line_then_quarter_arc(sign):
    path = line_arc(sign * 90.0)
    assert path.length_m == pytest.approx(12.0 + 3.0 * math.pi / 2, abs=1e-12)
    assert path.duration_s == pytest.approx(path.length_m / 0.4, abs=1e-12)
    # end of the line: (12, 0) heading 0
    np.testing.assert_allclose(path.pose_at_arclength(12.0), [12.0, 0.0, 0.0], atol=1e-12)
    # end of the arc: centre (12, +-3); the end is (15, +-3) heading +-90 deg
    np.testing.assert_allclose(path.end_pose, [15.0, sign * 3.0, sign * math.pi / 2], atol=1e-12)
    # half way round the arc: 45 deg
    a = math.pi / 4
    np.testing.assert_allclose(path.pose_at_arclength(12.0 + 3.0 * a),
                               [12.0 + 3.0 * math.sin(a), sign * 3.0 * (1 - math.cos(a)), sign * a], atol=1e-12)
    assert path.curvature_at_arclength(5.0) == 0.0
    assert path.curvature_at_arclength(13.0) == pytest.approx(sign / 3.0)
    # every point of the arc is at distance 3 from the centre
    s = np.linspace(12.0, path.length_m, 50)
    p = path.pose_at_arclength(s)
    np.testing.assert_allclose(np.hypot(p[:, 0] - 12.0, p[:, 1] - sign * 3.0), 3.0, atol=1e-12)


def test_pose_at_time_moves_at_the_set_speed_and_stops_at_the_end():
    path = line_arc(90.0, speed=0.5)
    np.testing.assert_allclose(path.pose_at_time(0.0), [0.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(path.pose_at_time(10.0), [5.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(path.pose_at_time(1e6), path.end_pose, atol=1e-12)
    np.testing.assert_allclose(path.pose_at_time(-3.0), [0.0, 0.0, 0.0], atol=1e-15)
    t = np.array([0.0, 10.0, 30.0, 1e6])
    np.testing.assert_allclose(path.arclength_at_time(t), [0.0, 5.0, 15.0, path.length_m])
    assert path.pose_at_time(t).shape == (4, 3)


def test_heading_is_the_tangent_and_the_path_is_continuous():
    """A path of several pieces: finite differences of the position give the heading, and the
    pieces join without gaps (each starts where the previous ends)."""
    segs = (Segment.line(2.0), Segment.arc(1.5, math.radians(120)), Segment.line(1.0),
            Segment.arc(4.0, math.radians(-200)), Segment.line(3.0))
    path = ReferencePath((1.0, -2.0), 0.4, segs, 0.3)
    s = np.linspace(0.0, path.length_m, 20001)
    p = path.pose_at_arclength(s)
    step = np.diff(p[:, :2], axis=0)
    assert np.max(np.abs(np.hypot(step[:, 0], step[:, 1]) - (s[1] - s[0]))) < 1e-8  # unit speed, no jumps
    joints = np.cumsum([g.length_m for g in segs])[:-1]
    inside = ~np.any((s[:-1, None] < joints) & (s[1:, None] > joints), axis=1)  # intervals within one piece
    assert inside.sum() >= len(inside) - len(joints)
    mid_heading = p[:-1, 2] + 0.5 * np.diff(p[:, 2])
    np.testing.assert_allclose(np.arctan2(step[inside, 1], step[inside, 0]),
                               np.arctan2(np.sin(mid_heading[inside]), np.cos(mid_heading[inside])), atol=1e-8)
    # curvature = d heading / d s
    curv = path.curvature_at_arclength(s[:-1] + 1e-9)
    np.testing.assert_allclose((np.diff(p[:, 2]) / (s[1] - s[0]))[inside], curv[inside], atol=1e-6)
    # total turn of the heading
    assert p[-1, 2] == pytest.approx(0.4 + math.radians(120 - 200), abs=1e-12)


def test_full_circle_returns_to_start():
    path = ReferencePath((2.0, 1.0), 1.0, (Segment.arc(2.0, 2 * math.pi),), 0.4)
    np.testing.assert_allclose(path.end_pose[:2], [2.0, 1.0], atol=1e-12)
    assert path.end_pose[2] == pytest.approx(1.0 + 2 * math.pi, abs=1e-12)
    assert path.length_m == pytest.approx(4 * math.pi)


def test_project_finds_the_nearest_point():
    path = line_arc(90.0)
    assert path.project((5.0, 0.7), 5.5) == pytest.approx(5.0, abs=0.05)
    # a point beside the arc at 45 deg (outside, 1 m further from the centre)
    a = math.pi / 4
    q = (12.0 + 4.0 * math.sin(a), 3.0 - 4.0 * math.cos(a))
    assert path.project(q, 12.0 + 3.0 * a) == pytest.approx(12.0 + 3.0 * a, abs=0.05)


def test_polyline_spans_the_path():
    path = line_arc(-45.0)
    pts = path.polyline(0.1)
    np.testing.assert_allclose(pts[0], [0.0, 0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(pts[-1], path.end_pose, atol=1e-12)
    assert np.max(np.hypot(*np.diff(pts[:, :2], axis=0).T)) <= 0.1 + 1e-12


def test_empty_path_is_refused():
    with pytest.raises(ValueError):
        ReferencePath((0.0, 0.0), 0.0, (), 0.4)


def test_projection_on_a_straight_piece_is_the_grid_search_of_the_path_s_points():
    """``project`` on a window that lies on one straight piece takes a shortcut to the points
    (no segment look-up, no sinc): the same answer as the grid search over
    ``pose_at_arclength``'s points, on straight paths and on the straight pieces of a bent one
    (windows across a joint or on an arc take the general way)."""
    import numpy as np

    def grid(p, xy, s_guess, window_m=1.0, n=81):
        s = np.minimum(np.maximum(np.linspace(s_guess - window_m, s_guess + window_m, n), 0.0), p.length_m)
        pts = p.pose_at_arclength(s)
        return float(s[int(np.argmin((pts[:, 0] - xy[0]) ** 2 + (pts[:, 1] - xy[1]) ** 2))])

    rng = np.random.default_rng(5)
    paths = (ReferencePath((0.0, -4.0), np.pi / 2, (Segment.line(8.0),), 0.4),
             ReferencePath((1.0, 2.0), 0.3, (Segment.line(3.0), Segment.arc(2.0, 1.2), Segment.line(4.0)), 0.4))
    for k in range(4000):
        p = paths[k % 2]
        s_guess, xy = rng.uniform(-1.0, p.length_m + 1.0), rng.uniform(-5.0, 5.0, 2)
        assert p.project(xy, s_guess, window_m=1.0) == grid(p, xy, s_guess)


def test_the_compiled_projection_on_a_line_is_the_numpy_one_bit_for_bit():
    """``project`` (the compiled ``_project_on_line`` where the window lies on one straight
    piece) against its numpy form ``_project_samples`` on every kind of window: inside a
    line, across a joint, on an arc, clipped at either end, tiny, zero-length and wide, with
    the guess and the point anywhere: the same arc length to the last bit."""
    import numpy as np

    rng = np.random.default_rng(17)
    paths = (ReferencePath((0.0, -4.0), np.pi / 2, (Segment.line(8.0),), 0.4),
             ReferencePath((1.0, 2.0), 0.3, (Segment.line(3.0), Segment.arc(2.0, 1.2), Segment.line(4.0)), 0.4),
             ReferencePath((-2.0, 0.5), -2.0, (Segment.arc(1.5, -0.8), Segment.line(0.7), Segment.line(2.0)), 0.3))
    compiled = 0
    for k in range(6000):
        p = paths[k % 3]
        window = (1.0, 2.0, 0.05, 0.0, 5.0)[k % 5]
        samples = (81, 81, 2, 7, 161)[k // 5 % 5]
        s_guess = float(rng.uniform(-2.0, p.length_m + 2.0))
        xy = tuple(rng.uniform(-6.0, 6.0, 2).tolist())
        got = p.project(xy, s_guess, window, samples)
        assert got == p._project_samples(xy, s_guess, window, samples)
        compiled += not math.isnan(_project_on_line(xy[0], xy[1], s_guess, window, samples, p._length,
                                                    *p.__dict__["_line_arrays"]))
    assert 1000 < compiled < 6000  # both ways taken


def test_a_clock_started_part_way_joins_the_robot_where_it_is_on_the_path():
    """The improved clock's first sample after a reset at t > 0 (a robot's own clock): it began
    at the path's start and searched 1 m around it, so a robot at the end at t = 31 s was told to
    reverse towards the start, and one on schedule 6 m along was told to stop. A clock started
    at t = 0, the simulator's, goes as before."""
    from casadi_gpc.progress import ReferenceClock
    path = ReferencePath((0.0, 0.0), 0.0, (Segment.line(4.0), Segment.arc(2.0, math.radians(90.0)),
                                           Segment.line(6.0)), 0.4)
    for t, s_true in ((15.0, 6.0), (31.0, path.length_m), (1e5, path.length_m), (8.0, 3.2)):
        clock = ReferenceClock(0.5, max_lead_m=0.5)
        x, y, _ = path.pose_at_arclength(np.array([s_true]))[0]
        s = clock.update(path, t, (x, y))
        assert s == pytest.approx(min(s_true + 0.5, 0.4 * t, path.length_m), abs=0.02), t
        # and on from there as a clock that had run all along
        clock.update(path, t + 0.5, (x, y))
        assert clock.s_m >= s - 1e-12
    a, b = ReferenceClock(0.5, max_lead_m=0.5), ReferenceClock(0.5, max_lead_m=0.5)
    b.update(path, 20.0, (8.0, 8.0))
    b.reset()
    for k in range(30):  # reset, then from t = 0: the same numbers as a fresh clock
        xy = (0.3 * k * 0.5, 0.01 * k)
        assert a.update(path, k * 0.5, xy) == b.update(path, k * 0.5, xy)
