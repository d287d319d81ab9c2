"""The scenario object: what a scenario file describes, validated and in SI units."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from casadi_gpc.geometry import distance_to_segments_m, nearest_on_segments
from casadi_gpc.reference import ReferencePath
from casadi_gpc.robot import RobotParams, RobotState, arc_step
from casadi_gpc.types import StaticObstacle

__all__ = ["MovingObstacleSpec", "WalkerSpec", "TrackSpec", "Wall", "Sensing", "Faults", "Scenario", "TRACK_BEHAVIOURS"]


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


TRACK_BEHAVIOURS = ("replay", "orca", "social_force")
"""What a mover with a recorded track does: replay it exactly (open loop), or follow it as a
walker that avoids the others (navground's ORCA or social force)."""


SPEED_SPAN_S = 0.01
"""The shortest time over which a track's speed is taken (:attr:`TrackSpec.max_recorded_speed_mps`):
below a video's frame (0.04 s at 25 fps, 0.017 s at 60)."""


def within_window(t, start, end):
    """Whether times ``t`` fall in the windows ``[start, end]`` (a track's first to last row,
    inclusive, 1e-9 s either side), broadcast: the one rule of when a track mover exists."""
    return (t >= start - 1e-9) & (t <= end + 1e-9)


@dataclass(frozen=True)
class TrackSpec:
    """A mover that follows a recorded track (a pedestrian of a recording).

    ``track`` holds the ``(t_s, x_m, y_m)`` rows, times strictly increasing (as the file
    gives them; :attr:`times_s` and :attr:`xy_m` are their arrays); the position is linear
    between rows. The mover exists only from its first row's time to its last
    (:meth:`exists_at`): before and after, it is nowhere (no measurement, no collision).
    ``behaviour`` ``"replay"`` is the recording exactly; ``"orca"`` / ``"social_force"`` a
    walker that heads at every instant for where its recording says it should be while
    avoiding the other movers (and the robot when ``sees_robot``), and leaves at its last
    row's time (:mod:`scenarios.movers`).
    """

    radius_m: float
    track: tuple[tuple[float, float, float], ...]
    behaviour: str = "replay"
    sees_robot: bool = False

    def __post_init__(self):
        rows = np.asarray(self.track, dtype=float).reshape(-1, 3)
        rows.flags.writeable = False
        object.__setattr__(self, "_rows", rows)

    @property
    def times_s(self) -> np.ndarray:
        return self._rows[:, 0]

    @property
    def xy_m(self) -> np.ndarray:
        return self._rows[:, 1:]

    @property
    def start_s(self) -> float:
        return float(self.times_s[0])

    @property
    def end_s(self) -> float:
        return float(self.times_s[-1])

    @property
    def position_m(self) -> tuple[float, float]:
        """Where the track starts (its first row)."""
        return float(self.xy_m[0, 0]), float(self.xy_m[0, 1])

    def exists_at(self, t_s):
        """Whether the mover is in the scene at time(s) ``t_s`` (first to last row, inclusive)."""
        return within_window(np.asarray(t_s, dtype=float), self.times_s[0], self.times_s[-1])

    def recorded_at(self, t_s) -> np.ndarray:
        """The recorded position at time(s) ``t_s``, linear between rows and held at the
        ends: ``(2,)`` for a scalar, ``(len(t), 2)`` for an array."""
        t = np.asarray(t_s, dtype=float)
        out = np.stack([np.interp(t, self.times_s, self.xy_m[:, 0]), np.interp(t, self.times_s, self.xy_m[:, 1])],
                       axis=-1)
        return out

    def recorded_velocity_at(self, t_s: float) -> np.ndarray:
        """The recorded velocity over the row interval that holds ``t_s`` (zero outside the
        track's time)."""
        if not bool(self.exists_at(t_s)):
            return np.zeros(2)
        k = int(np.clip(np.searchsorted(self.times_s, t_s, side="right") - 1, 0, len(self.times_s) - 2))
        return (self.xy_m[k + 1] - self.xy_m[k]) / (self.times_s[k + 1] - self.times_s[k])

    @property
    def max_recorded_speed_mps(self) -> float:
        """The fastest speed between rows, each row taken to the first row at least
        :data:`SPEED_SPAN_S` after it (the next, wherever rows are that far apart: every
        recording and suite gpcnav ships has them 0.2 s or more apart). Rows microseconds
        apart, which a file may hold, would otherwise make a walker's top speed thousands of
        m/s (:data:`scenarios.movers.TRACK_SPEED_FACTOR` times this)."""
        t, xy = self.times_s, self.xy_m
        n = len(t)
        if n < 2:
            return 0.0
        i = np.arange(n - 1)
        j = np.minimum(np.maximum(np.searchsorted(t, t[:-1] + SPEED_SPAN_S, side="left"), i + 1), n - 1)
        d = xy[j] - xy[i]
        return float((np.hypot(d[:, 0], d[:, 1]) / (t[j] - t[i])).max())


@dataclass(frozen=True)
class Wall:
    """A thin wall, known exactly (a map): the polyline through ``points`` (at least two,
    no segment of zero length). The robot collides when its disc touches a segment; walkers
    (orca, social_force) avoid it; constant and replayed movers ignore it."""

    points: tuple[tuple[float, float], ...]

    @property
    def segments(self) -> np.ndarray:
        """``(n, 2, 2)``: each segment's two end points."""
        pts = np.asarray(self.points, dtype=float)
        return np.stack([pts[:-1], pts[1:]], axis=1)

    def nearest_point(self, xy) -> np.ndarray:
        """The point of the polyline nearest to each point of ``xy`` (``(..., 2)``)."""
        seg = self.segments
        near = nearest_on_segments(xy, seg[:, 0], seg[:, 1])                # (..., n, 2)
        k = np.argmin(((np.asarray(xy, dtype=float)[..., None, :] - near) ** 2).sum(-1), axis=-1)
        return np.take_along_axis(near, k[..., None, None], axis=-2)[..., 0, :]

    def distance_m(self, xy) -> np.ndarray:
        """Distance from each point of ``xy`` (``(..., 2)``) to the polyline."""
        seg = self.segments
        return distance_to_segments_m(xy, seg[:, 0], seg[:, 1]).min(axis=-1)


@dataclass(frozen=True)
class Sensing:
    position_noise_std_m: float = 0.02
    seed: int = 0
    range_m: float | None = None
    """A mover is measured only while its centre is within this distance of the robot's
    centre (None: no limit)."""


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
    moving: tuple[MovingObstacleSpec | WalkerSpec | TrackSpec, ...] = ()
    static: tuple[StaticObstacle, ...] = ()
    sensing: Sensing = field(default_factory=Sensing)
    faults: Faults = field(default_factory=Faults)
    description: str = ""
    source: str = ""
    """The file it was read from, if any."""
    walls: tuple[Wall, ...] = ()

    def with_seed(self, seed: int) -> "Scenario":
        from dataclasses import replace
        return replace(self, sensing=replace(self.sensing, seed=int(seed)))
