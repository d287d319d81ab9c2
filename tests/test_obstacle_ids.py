"""An obstacle id is an integer (``ObstacleMeasurement.obstacle_id: int``): the filters, the
networks' features and the planner's learned forecasts near walls key on it. A robot's tracker
that names people ("person_3") had the deployed network fail at its first decision deep in the
features (``int('person_3')``), and the planner run without complaint until a map with walls
came into view, then fail mid-episode (``'person_3' + 10000000``: a TypeError in its walls
forecast). A float id (1.5 and 1.7) was cut to one label, 1, in the network's track estimates.
Now the observation refuses such an id in one line, before any controller sees it."""
from __future__ import annotations

import numpy as np
import pytest

from casadi_gpc import Observation, ObstacleMeasurement, ReferencePath, RobotState, Segment

REF = ReferencePath((0.0, 0.0), 0.0, (Segment.line(10.0),), 0.4)
ROBOT = RobotState(0.0, 0.0, 0.0, 0.0, 0.0)


@pytest.mark.parametrize("bad", ["person_0", 1.5, None, (1, 2), 2.0])
def test_an_obstacle_id_that_is_not_an_integer_is_refused_in_one_line(bad):
    with pytest.raises(ValueError) as exc:
        Observation(0.5, ROBOT, REF, (ObstacleMeasurement(0, (4.0, 1.0), 0.3),
                                      ObstacleMeasurement(bad, (3.0, 0.0), 0.3)))
    assert str(exc.value).startswith(f"observation at t=0.5 s: moving obstacle id {bad!r} is ")
    assert "\n" not in str(exc.value)


def test_integer_ids_of_any_integer_type_pass():
    for i in (3, np.int64(3), np.int32(3), np.uint16(3), -1, 10 ** 12):
        Observation(0.5, ROBOT, REF, (ObstacleMeasurement(i, (3.0, 0.0), 0.3),))


def test_the_deployed_network_and_the_planner_never_see_a_named_id():
    """The symptom, end to end: the network's first decision and the planner's first decision
    near a wall were a traceback from inside (now: the observation is refused before)."""
    from nn_export import OnnxPolicy
    with pytest.raises(ValueError, match="is a str, not an integer"):
        OnnxPolicy().decide(Observation(0.0, ROBOT, REF, (ObstacleMeasurement("person_3", (3.0, 0.0), 0.3),)))


@pytest.mark.parametrize("bad", [("1", "2"), (True, False), (None, 1.0), (1 + 2j, 0.0), "ab", (1.0, 2.0, 3.0),
                                 [[1.0, 2.0]], 5.0, np.array(["1", "2"]), np.array([True, False])])
def test_a_measured_position_that_is_not_two_numbers_is_refused_in_one_line(bad):
    """A position is two real numbers, or None when not measured. Strings ("1", "2") and booleans
    were read as numbers, (None, 1.0) taken for a missing measurement, and a complex number or a word
    failed inside the filter with an error that named neither the obstacle nor the time."""
    with pytest.raises(ValueError) as exc:
        Observation(0.5, ROBOT, REF, (ObstacleMeasurement(0, (4.0, 1.0), 0.3), ObstacleMeasurement(7, bad, 0.3)))
    assert str(exc.value).startswith("observation at t=0.5 s: moving obstacle 7 has position ")
    assert "\n" not in str(exc.value)


def test_a_measured_position_of_any_real_numbers_passes_and_a_non_finite_one_is_a_missing_measurement():
    for z in (None, (3.0, 0.0), [3.0, 0.0], (3, 0), (np.float32(3.0), np.float64(0.0)), np.array([3.0, 0.0]),
              np.array([3, 0]), (float("nan"), 0.0), (float("inf"), 1.0)):
        Observation(0.5, ROBOT, REF, (ObstacleMeasurement(1, z, 0.3),))
