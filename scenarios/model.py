"""The scenario object: what a scenario file describes, validated and in SI units."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from casadi_gpc.reference import ReferencePath
from casadi_gpc.robot import RobotParams, RobotState, arc_step
from casadi_gpc.types import StaticObstacle

__all__ = ["MovingObstacleSpec", "WalkerSpec", "Sensing", "Faults", "Scenario"]


@dataclass(frozen=True)
class MovingObstacleSpec:
    """A moving obstacle's true motion: constant speed and turn rate from t = 0."""

    position_m: tuple[float, float]
    heading_rad: float
    speed_mps: float
    radius_m: float
    turn_rate_rad_s: float = 0.0

    behaviour = "constant"

    def state_at(self, t_s):
        """True ``(x, y, heading)`` at time(s) ``t_s`` (exact arcs)."""
        return arc_step(np, self.position_m[0], self.position_m[1], self.heading_rad,
                        self.speed_mps, self.turn_rate_rad_s, np.asarray(t_s, dtype=float))


@dataclass(frozen=True)
class WalkerSpec:
    """A mover that walks to a goal at its preferred speed and avoids the other movers
    (``behaviour`` ``"orca"`` or ``"social_force"``: navground's ORCA or social force model;
    :mod:`scenarios.movers`), and the robot when ``sees_robot``. It stands at its goal
    once there."""

    position_m: tuple[float, float]
    radius_m: float
    behaviour: str
    goal_m: tuple[float, float]
    preferred_speed_mps: float
    sees_robot: bool = False


@dataclass(frozen=True)
class Sensing:
    position_noise_std_m: float = 0.02
    seed: int = 0


@dataclass(frozen=True)
class Faults:
    """Injected faults (the ``[faults]`` table; docs/faults.md)."""

    dropout_prob: float = 0.0
    """Probability that a moving obstacle's measurement is missing at a sample."""
    outlier_prob: float = 0.0
    """Probability that a measurement is replaced by one ``outlier_distance_m`` away."""
    outlier_distance_m: float = 3.0
    delay_steps: int = 0
    """Measurements arrive this many samples late."""
    solver_failure_prob: float = 0.0
    """Probability that the planner's solver is made to fail at a sample."""

    @property
    def any(self) -> bool:
        return bool(self.dropout_prob or self.outlier_prob or self.delay_steps or self.solver_failure_prob)


@dataclass(frozen=True)
class Scenario:
    name: str
    duration_s: float
    robot_start: RobotState
    reference: ReferencePath
    robot: RobotParams = field(default_factory=RobotParams)
    moving: tuple[MovingObstacleSpec | WalkerSpec, ...] = ()
    static: tuple[StaticObstacle, ...] = ()
    sensing: Sensing = field(default_factory=Sensing)
    faults: Faults = field(default_factory=Faults)
    description: str = ""
    source: str = ""
    """The file it was read from, if any."""

    def with_seed(self, seed: int) -> "Scenario":
        from dataclasses import replace
        return replace(self, sensing=replace(self.sensing, seed=int(seed)))
