"""A mover the sensor stops listing is gone for the controller: its filter is dropped, and the
banks count ``dropped_tracks`` (docs/scenarios.md). The planner's counters and a check layer's own
bank reported it; the deployed network's did not (its counters copied five of the bank's counts by
name): 7 500 tracks dropped in 100 000 decisions, none said."""
from __future__ import annotations

from casadi_gpc import Observation, ObstacleMeasurement, ReferencePath, RobotState, Segment
from casadi_gpc.safety import Shield
from nn_export import OnnxPolicy

REF = ReferencePath((0.0, 0.0), 0.0, (Segment.line(10.0),), 0.4)


def _run(controller) -> dict:
    robot = RobotState(0.0, 0.0, 0.0)
    listed = [(1, 2, 3), (1, 2, 3), (1, 3), (3,), (3, 4), (4,)]  # 2 leaves, then 1, then 3
    for k, ids in enumerate(listed):
        moving = tuple(ObstacleMeasurement(i, (5.0 + i, 2.0 + 0.1 * k), 0.3) for i in ids)
        controller.decide(Observation(0.5 * k, robot, REF, moving))
    return controller.counters


def test_the_deployed_network_reports_the_tracks_it_dropped():
    assert _run(OnnxPolicy())["dropped_tracks"] == 3
    assert _run(Shield(OnnxPolicy()))["dropped_tracks"] == 3


def test_as_the_planner_does():
    from casadi_gpc import GPCController, preset
    assert _run(GPCController(preset("improved")))["dropped_tracks"] == 3
