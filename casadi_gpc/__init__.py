"""casadi_gpc: the robot's side. Its model and reference, estimation (the obstacle EKFs),
the planner's problem, its solvers, the GPC planner and the check layer, in rooms that import
downwards only: ``estimation/``, ``problem/``, ``solvers/``, ``planner/``, ``safety/``
(docs/architecture.md). The world it is tested in is ``scenarios``.

The numpy-only pieces (``robot``, ``reference``, ``estimation``, ``progress``, ``types``,
``config``, ``safety``) import without CasADi, so the deployed policy can use them; the
planner itself (``problem.cost``, ``planner.gpc``) needs CasADi and is imported lazily here.
"""
from .config import DEFAULT_PRESET, PRESETS, PlannerConfig, preset
from .estimation.ekf import EKFSettings, ObstacleEKF
from .reference import ReferencePath, Segment
from .robot import RobotParams, RobotState, arc_step, robot_step
from .types import ControlDecision, Observation, ObstacleForecast, ObstacleMeasurement, Policy, StaticObstacle

__all__ = [
    "DEFAULT_PRESET", "PRESETS", "PlannerConfig", "preset", "EKFSettings", "ObstacleEKF", "ReferencePath",
    "Segment", "RobotParams", "RobotState", "arc_step", "robot_step", "ControlDecision", "Observation",
    "ObstacleForecast", "ObstacleMeasurement", "Policy", "StaticObstacle", "GPCController",
]


def __getattr__(name):
    if name == "GPCController":
        from .planner.gpc import GPCController
        return GPCController
    raise AttributeError(name)
