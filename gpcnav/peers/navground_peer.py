"""ORCA, HRVO and the social force model as gpcnav controllers: navground's own behaviours
(``pip install navground``, C++ core) with its two-wheel differential-drive kinematics.

Each decision:

1. the robot's pose and its current twist (from the wheel speeds it drives now) are given
   to the behaviour, in the world frame: navground's velocity-obstacle behaviours build
   their constraints from the current velocity, so it must be the robot's real one;
2. the moving obstacles enter as navground ``Neighbor`` s with the positions and velocities
   of the one EKF bank the GPC plans with (:class:`casadi_gpc.estimation.tracking.TrackBank`, fed the
   same measured positions, stepped at this controller's sample time with the planner's
   noise per second, :meth:`~casadi_gpc.estimation.ekf.EKFSettings.for_sample_time`); a track seen once
   has no velocity yet and enters standing; static obstacles enter as ``Disc`` s;
3. the target is navground's path following: reach the end of the reference path along the
   path (``Target.Point(end, along_path=...)``, navground's look-ahead and relaxation time),
   at the reference speed as the preferred (``optimal``) speed, the wheel limit as the
   maximal speed;
4. the behaviour's twist becomes wheel speeds through the ``2WDiff`` kinematics (wheel axis
   = the robot's wheel base, maximal speed = its wheel limit), and the change from the
   current wheel speeds is scaled down, both wheels by the same factor, to the robot's
   acceleration limit (``max_wheel_accel_mps2 x T``), so that the turn the behaviour asked
   for keeps its ratio of speed to turn rate (the simulator would clip each wheel apart).

Settings are dataclasses (:class:`OrcaSettings`, :class:`HrvoSettings`,
:class:`SocialForceSettings`), each field documented with why it has its value;
``docs/peers.md`` has the measurements behind them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from casadi_gpc.estimation.ekf import EKFSettings
from casadi_gpc.robot import RobotParams
from casadi_gpc.estimation.tracking import TrackBank
from casadi_gpc.types import ControlDecision, Observation

__all__ = ["NavgroundSettings", "OrcaSettings", "HrvoSettings", "SocialForceSettings", "NavgroundPeer",
           "limit_wheel_change", "DEFAULT_SAFETY_MARGIN_M", "NAVGROUND_PEERS"]

DEFAULT_SAFETY_MARGIN_M = 0.15
"""The contract's safety margin of the baselines: navground's ``safety_margin``, added to the
robot's radius when a behaviour checks clearances."""


@dataclass(frozen=True)
class NavgroundSettings:
    """What every navground peer shares."""

    sample_time_s: float = 0.1
    """Control period. navground's behaviours are reactive (one velocity per call, no plan):
    they are run at navground's usual period of 0.1 s, the grid our walkers also decide on.
    The simulator holds the wheel speeds over it."""
    safety_margin_m: float = DEFAULT_SAFETY_MARGIN_M
    """navground's ``safety_margin`` (contract default 0.15 m, changeable)."""
    horizon_m: float = 10.0
    """navground's ``horizon``: how far the behaviour looks (m). 10 m, CrowdNav's neighbour
    distance for ORCA; every obstacle of our scenes is inside it."""
    path_look_ahead_m: float = 1.0
    """navground's ``path_look_ahead``: the point of the path the robot heads for is this far
    ahead of its projection on the path (navground's default)."""
    path_tau_s: float = 0.5
    """navground's ``path_tau``: relaxation time towards the path (navground's default)."""
    goal_tolerance_m: float = 0.1
    """The target point (end of the path) counts as reached within this distance: well
    inside the 0.3 m of the contract's goal rule, so the robot stops where the goal counts."""

    behaviour = ""
    """navground's behaviour type (``Behavior.make_type``)."""

    def behaviour_properties(self) -> dict:
        """navground properties of the behaviour type (``Behavior.set``)."""
        return {}


@dataclass(frozen=True)
class OrcaSettings(NavgroundSettings):
    """ORCA (van den Berg et al. 2011), navground's ``ORCA``."""

    time_horizon_s: float = 10.0
    """ORCA's time horizon for other agents: navground's default, 10 s. CrowdNav's 5 s
    (this adapter's first value) made the robot collide with walkers that do not see it in
    16 and 23 of 200 development episodes (navground's Antipodal scene, blind walkers, and
    circle-crossing), 10 s in 0 and 5; navground running its ORCA on the same files, 3 and 2
    (docs/peers.md, "The peers as navground runs them")."""
    static_time_horizon_s: float = 10.0
    """The same for static obstacles (navground's default)."""
    effective_center: bool = False
    """navground's holonomic effective centre for a differential drive. Off (navground's
    default): with it the robot never drove faster than 0.28 m/s of the 0.4 asked, and took
    a third longer to the goal for no fewer collisions (docs/peers.md)."""

    behaviour = "ORCA"

    def behaviour_properties(self) -> dict:
        return {"time_horizon": self.time_horizon_s, "static_time_horizon": self.static_time_horizon_s,
                "effective_center": self.effective_center}


@dataclass(frozen=True)
class HrvoSettings(NavgroundSettings):
    """HRVO (Snape et al. 2011), navground's ``HRVO``, with navground's defaults."""

    uncertainty_offset: float = 0.0
    """navground's ``uncertainty_offset`` (its default): the EKF's velocities are used as
    they are."""

    behaviour = "HRVO"

    def behaviour_properties(self) -> dict:
        return {"uncertainty_offset": self.uncertainty_offset}


@dataclass(frozen=True)
class SocialForceSettings(NavgroundSettings):
    """The social force model (Helbing and Molnar 1995), navground's ``SocialForce`` (written
    in Python: about 90 us per neighbour). navground's model has no radius and no safety
    margin (its potentials act on centre distances), so ``safety_margin_m`` does not
    change it; the repulsion's strength is raised instead."""

    tau_s: float = 0.5
    """Relaxation time towards the desired velocity (Helbing's, navground's default)."""
    neighbour_strength: float = 5.0
    """``v_a`` (m^2/s^2), strength of the repulsion by a neighbour. Helbing's 2.1 is made for
    pedestrians about 0.3 m across; with our 0.35 m robot it collided in 27.5 % of the
    development crowd episodes, 5.0 in none (docs/peers.md)."""
    neighbour_range_m: float = 0.3
    """``v_r``: range of that repulsion (navground's default)."""
    obstacle_strength: float = 10.0
    """``u_a``: strength of the repulsion by a static obstacle (navground's default)."""
    obstacle_range_m: float = 0.2
    """``u_r``: its range (navground's default)."""

    behaviour = "SocialForce"

    def behaviour_properties(self) -> dict:
        return {"tau": self.tau_s, "v_a": self.neighbour_strength, "v_r": self.neighbour_range_m,
                "u_a": self.obstacle_strength, "u_r": self.obstacle_range_m}


def limit_wheel_change(current: tuple[float, float], target: tuple[float, float], max_change_mps: float
                       ) -> tuple[float, float]:
    """``target`` wheel speeds reached from ``current`` within ``max_change_mps`` per wheel:
    the change is scaled, both wheels by the same factor, so its direction (the ratio of
    the speed change to the turn-rate change) is kept."""
    d0, d1 = target[0] - current[0], target[1] - current[1]
    scale = max(1.0, abs(d0) / max_change_mps, abs(d1) / max_change_mps)
    return current[0] + d0 / scale, current[1] + d1 / scale


def _navground_path(reference, step_m: float = 0.05):
    """navground's ``Path`` of a :class:`~casadi_gpc.reference.ReferencePath` (its
    projection on a polyline of ``step_m``, its exact poses and curvatures)."""
    from navground import core
    L = reference.length_m
    s_grid = np.linspace(0.0, L, max(2, int(math.ceil(L / step_m)) + 1))
    xy = reference.pose_at_arclength(s_grid)[:, :2]

    def project(position, s_from, s_to) -> float:
        lo, hi = np.searchsorted(s_grid, [s_from - 1e-9, s_to + 1e-9])
        if hi <= lo:
            return float(min(max(s_from, 0.0), L))
        d2 = np.sum((xy[lo:hi] - np.asarray(position, dtype=float)) ** 2, axis=1)
        return float(s_grid[lo + int(np.argmin(d2))])

    def curve(s):
        x, y, h = reference.pose_at_arclength(s)
        return np.array((x, y), dtype=np.float32), float(h), float(reference.curvature_at_arclength(s))

    return core.Path(project, curve, L)


class NavgroundPeer:
    """A navground behaviour answering the Policy protocol (``reset``, ``decide``,
    ``sample_time_s``).

    Parameters
    ----------
    settings : NavgroundSettings
        :class:`OrcaSettings`, :class:`HrvoSettings` or :class:`SocialForceSettings`.
    robot : RobotParams
        The robot's geometry and limits (a scenario's ``robot``).
    """

    def __init__(self, settings: NavgroundSettings, robot: RobotParams | None = None):
        from navground import core  # noqa: F401  (fail here, not at the first decision)
        if not settings.behaviour:
            raise ValueError("NavgroundSettings needs a behaviour: use OrcaSettings, HrvoSettings or "
                             "SocialForceSettings")
        self.settings = settings
        self.robot = robot or RobotParams()
        self.sample_time_s = settings.sample_time_s
        self.reset()

    @property
    def name(self) -> str:
        return self.settings.behaviour

    def reset(self) -> None:
        from navground import core
        s, r = self.settings, self.robot
        kin = core.Kinematics.make_type("2WDiff")
        kin.wheel_axis = r.wheel_base_m
        kin.max_speed = r.max_wheel_speed_mps
        b = core.Behavior.make_type(s.behaviour)
        b.kinematics = kin
        b.radius = r.radius_m
        b.safety_margin = s.safety_margin_m
        b.horizon = s.horizon_m
        b.path_look_ahead = s.path_look_ahead_m
        b.path_tau = s.path_tau_s
        for name, value in s.behaviour_properties().items():
            if not b.has(name):
                raise ValueError(f"navground's {s.behaviour} has no property {name!r}")
            b.set(name, value)
        self._behaviour, self._kinematics = b, kin
        self._reference = None
        self._walls, self._lines = None, []
        self.counters = {"missed_measurements": 0, "outliers": 0, "unestimated_tracks": 0, "acceleration_limited": 0}
        self.bank = TrackBank(s.sample_time_s, EKFSettings().for_sample_time(s.sample_time_s), self.counters)

    def _set_target(self, reference) -> None:
        from navground import core
        b = self._behaviour
        b.optimal_speed = reference.speed_mps
        b.max_speed = self.robot.max_wheel_speed_mps
        end = np.asarray(reference.end_pose[:2], dtype=float)
        b.target = core.Target.Point(end, self.settings.goal_tolerance_m, _navground_path(reference))
        self._reference = reference

    def neighbours(self, observation: Observation) -> list:
        """The moving obstacles as navground sees them: the EKF bank's positions and
        velocities (one step of the bank: call once per decision)."""
        from navground import core
        out = []
        for m, ekf in self.bank.step(observation.moving, observation.t_s):
            x, y = ekf.state_[:2]
            vel = ekf.velocity_mps
            out.append(core.Neighbor(np.array((x, y)), m.radius_m, np.array(vel), int(m.obstacle_id)))
        return out

    def decide(self, observation: Observation) -> ControlDecision:
        from navground import core
        b, r, st = self._behaviour, self.robot, observation.robot
        if observation.reference is not self._reference:
            self._set_target(observation.reference)
        speed = 0.5 * (st.v_right_mps + st.v_left_mps)
        twist = core.Twist2((speed * math.cos(st.heading_rad), speed * math.sin(st.heading_rad)),
                            (st.v_right_mps - st.v_left_mps) / r.wheel_base_m, frame=core.Frame.absolute)
        b.position = np.array((st.x_m, st.y_m))
        b.orientation = st.heading_rad
        b.twist = twist
        b.actuated_twist = twist  # what the robot drives now, not what was last asked
        b.environment_state.neighbors = self.neighbours(observation)
        b.environment_state.static_obstacles = [core.Disc(np.asarray(s.position_m, dtype=float), s.radius_m)
                                                for s in observation.static]
        if observation.walls:  # walls as navground takes them: line obstacles
            if observation.walls is not self._walls:
                self._walls = observation.walls
                self._lines = [core.LineSegment(np.asarray(a, dtype=float), np.asarray(c, dtype=float))
                               for pts in observation.walls for a, c in zip(pts[:-1], pts[1:])]
            b.environment_state.line_obstacles = self._lines
        cmd = b.compute_cmd(self.sample_time_s, core.Frame.relative, True)
        left, right = self._kinematics.wheel_speeds(cmd)
        dv = r.max_step_change_mps(self.sample_time_s)
        vr, vl = limit_wheel_change((st.v_right_mps, st.v_left_mps), (right, left), dv)
        if abs(vr - right) > 1e-9 or abs(vl - left) > 1e-9:
            self.counters["acceleration_limited"] += 1
        return ControlDecision(float(vr), float(vl), reason=self.settings.behaviour)


NAVGROUND_PEERS = {"orca": OrcaSettings, "hrvo": HrvoSettings, "social_force": SocialForceSettings}
"""The registry's names of the navground peers -> their settings class."""
