"""A reference the robot cannot follow is refused when it is made, in one line, as a scenario
file's is (CONTRACT.md: a speed or length that is not positive, a number that is not finite).
Made in Python it was taken: a NaN start or speed, or an arc of radius 0 (an infinite curvature),
had both controllers brake at every decision for as long as it ran (16 of 16: the GPC's solves
all failed, the network's commands were not finite); a speed of 0 or below had the network creep
0.42 m in 8 s from a reference point standing at its start, and ``duration_s`` divide by zero; a
negative length was a path that ran backwards from its own start."""
from __future__ import annotations

import math

import numpy as np
import pytest

from casadi_gpc import ReferencePath, Segment

LINE = (Segment.line(5.0),)


@pytest.mark.parametrize("start, heading, segments, speed, field", [
    ((math.nan, 0.0), 0.0, LINE, 0.4, "start"),
    ((0.0, math.inf), 0.0, LINE, 0.4, "start"),
    ((0.0, 0.0), math.nan, LINE, 0.4, "heading"),
    ((0.0, 0.0), 0.0, LINE, math.nan, "speed"),
    ((0.0, 0.0), 0.0, LINE, 0.0, "speed"),
    ((0.0, 0.0), 0.0, LINE, -0.4, "speed"),
    ((0.0, 0.0), 0.0, (Segment.line(-3.0),), 0.4, "segment 0"),
    ((0.0, 0.0), 0.0, (Segment.line(2.0), Segment.line(math.nan)), 0.4, "segment 1"),
    ((0.0, 0.0), 0.0, (Segment(2.0, math.inf),), 0.4, "segment 0"),
])
def test_a_reference_no_robot_can_follow_is_refused(start, heading, segments, speed, field):
    with pytest.raises(ValueError) as exc:
        ReferencePath(start, heading, segments, speed)
    assert str(exc.value).startswith("reference path: ") and field in str(exc.value) and "\n" not in str(exc.value)


def test_an_arc_of_no_radius_is_refused():
    with pytest.raises(ValueError, match="segment 0"), np.errstate(divide="ignore"):
        ReferencePath((0.0, 0.0), 0.0, (Segment.arc(0.0, 1.0), Segment.line(3.0)), 0.4)


def test_what_a_path_message_gives_is_taken():
    """Repeated points (a piece of no length), numpy's numbers, a path of no length at all."""
    path = ReferencePath((np.float32(1.0), np.int64(2)), np.float64(0.5),
                         (Segment.line(3.0), Segment.line(0.0), Segment.arc(2.0, -0.5)), np.float32(0.4))
    assert path.length_m == pytest.approx(4.0)
    assert ReferencePath((0.0, 0.0), 0.0, (Segment.line(0.0),), 0.4).duration_s == 0.0
