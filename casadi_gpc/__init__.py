"""casadi_gpc: the robot model, obstacle EKF, the GPC planner, the simulator, metrics, plots.

The numpy-only pieces (``robot``, ``reference``, ``ekf``, ``progress``, ``types``,
``config``) import without CasADi, so the deployed policy can use them; the planner
itself (``cost``, ``gpc``) needs CasADi and is imported lazily here.
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
