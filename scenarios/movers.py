"""The moving obstacles' true motion in one episode: what the simulator shows the sensor and
checks collisions against.

Three kinds of movers (the scenario format's ``behaviour``):

- ``constant``: a fixed course, constant speed and turn rate from t = 0, in closed form
  (:meth:`MovingObstacleSpec.state_at <scenarios.model.MovingObstacleSpec.state_at>`).
- ``replay``: a recorded track (:class:`~scenarios.model.TrackSpec`), exactly, whatever the
  robot does (open loop), in closed form too.
- ``orca`` and ``social_force``: people who walk to a goal at a preferred speed and avoid the
  other movers (and the robot, when they see it), stepped by navground's own behaviours
  (``ORCA``, ``SocialForce``; C++ core, ``pip install navground``) with holonomic (``Omni``)
  kinematics. A walker stands at its goal once it is within :data:`GOAL_TOLERANCE_M` of it.
  A walker with a recorded track has no fixed goal: at every grid instant it heads for where
  its recording will be :data:`TRACK_LOOKAHEAD_S` later, at the speed that gets it there
  (at most :data:`TRACK_SPEED_FACTOR` times the track's fastest recorded speed), and leaves
  the scene at its last row's time. It enters where its recording starts, except that one
  who sees the robot never enters on it (:data:`ENTRY_CLEARANCE_M`, counted).

A mover with a track exists only from its first row's time to its last: outside that window
:meth:`MoverWorld.positions` gives NaN for it (nothing measures it, nothing collides with
it, no walker sees it).

The reacting movers are advanced on a fixed grid of :data:`CROWD_TIME_STEP_S`, independent
of the controller's sample time: at each grid instant every walker's behaviour is given the
positions and velocities of everything it sees at that instant (the other movers, the static
obstacles as discs, and the robot if ``sees_robot``) and answers a velocity, which it keeps
until the next grid instant. Positions between grid instants are therefore exactly linear,
and :meth:`MoverWorld.positions` interpolates them exactly. Nothing here is random: the
motion follows from the scenario (and the robot's motion, for walkers that see it).

navground is imported only when a scenario has walkers.
"""
from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

from .model import within_window

__all__ = ["CROWD_TIME_STEP_S", "ENTRY_CLEARANCE_M", "GOAL_TOLERANCE_M", "MOVER_SAFETY_MARGIN_M", "BEHAVIOURS",
           "MoverWorld"]

CROWD_TIME_STEP_S = 0.1
"""Grid of the walkers' decisions (navground's usual control period)."""
GOAL_TOLERANCE_M = 0.05
"""A walker this close to its goal stands there from then on."""
MOVER_SAFETY_MARGIN_M = 0.05
"""navground's ``safety_margin`` of every walker: without one, ORCA's discs touch to within
its numerical tolerance (measured: overlaps of ~1 mm in a head-on pair)."""
PERCEPTION_RANGE_M = 5.0
"""A walker sees what is this close (centre distance; navground's default behaviour horizon)."""
TRACK_LOOKAHEAD_S = 0.4
"""How far ahead on its recording a walker that follows a track aims (one row of the ETH/UCY
recordings)."""
TRACK_SPEED_FACTOR = 1.5
"""A walker that follows a track may walk this much faster than its fastest recorded speed to
catch up with its recording after giving way."""
ENTRY_CLEARANCE_M = 0.1
"""A walker who sees the robot enters the scene at least this far from the robot's disc: a
person who gives way to a robot does not step into it, where a recording, blind to the robot,
may start someone on the spot it stands on (``students003`` starts people in the middle of
its scene). 0.1 m: more than the robot covers in one grid step at its top speed (0.08 m), so
the walker's own avoidance has a step to act. A replayed track is never moved."""
BEHAVIOURS = {"orca": "ORCA", "social_force": "SocialForce"}
"""Scenario ``behaviour`` names of the walkers and navground's behaviour types."""

RobotMotion = Callable[[float], tuple[float, float, float, float]]
"""The robot's ``(x, y, vx, vy)`` at a time (m, m/s), for walkers that see it."""


class MoverWorld:
    """The movers of one episode, advanced in time by the simulator.

    Parameters
    ----------
    movers : sequence of mover specs
        Constant movers (with ``state_at``) and walkers (``behaviour`` in :data:`BEHAVIOURS`,
        ``goal_m``, ``preferred_speed_mps``, ``sees_robot``), in the scenario's order.
    statics : sequence of StaticObstacle
        What walkers also avoid.
    robot_radius_m : float
        The robot's disc, for walkers that see it.
    walls : sequence of Wall
        Polylines the walkers avoid (navground's line obstacles).
    """

    def __init__(self, movers: Sequence, statics: Sequence = (), robot_radius_m: float = 0.35,
                 walls: Sequence = ()):
        self.movers = tuple(movers)
        self.n = len(self.movers)
        self.radii = np.array([m.radius_m for m in self.movers], dtype=float)
        kinds = [getattr(m, "behaviour", "constant") for m in self.movers]
        self._walkers = [j for j, k in enumerate(kinds) if k in BEHAVIOURS]
        self._constant = [j for j, k in enumerate(kinds) if k == "constant"]
        self._replay = [j for j, k in enumerate(kinds) if k == "replay"]
        self._tracked = [j for j, m in enumerate(self.movers) if hasattr(m, "track")]
        """Movers with a recorded track (replayed or walking it): they exist in a window only."""
        # their windows, as arrays: which of them exist at a time is one comparison (a loop over
        # the movers, each asked alone, cost 60 ms a sample with the 415 people of a recording)
        self._track_start = np.array([self.movers[j].start_s for j in self._tracked], dtype=float)
        self._track_end = np.array([self.movers[j].end_s for j in self._tracked], dtype=float)
        self._replay_start = np.array([self.movers[j].start_s for j in self._replay], dtype=float)
        self._replay_end = np.array([self.movers[j].end_s for j in self._replay], dtype=float)
        self._robot_radius = float(robot_radius_m)
        self._statics = tuple(statics)
        self.steps = 0
        """Grid steps the walkers have taken (``counters["walker_steps"]``: the walkers' own
        decisions, summed over the steps)."""
        self.counters = {"walker_steps": 0, "arrived": 0, "entered_beside_robot": 0}
        if self._walkers:
            from navground import core
            self._behaviours = [_make_behaviour(self.movers[j]) for j in self._walkers]
            self._static_discs = [core.Disc(np.asarray(s.position_m, float), s.radius_m) for s in self._statics]
            self._lines = [core.LineSegment(np.asarray(a, float), np.asarray(b, float))
                           for w in walls for a, b in zip(w.points[:-1], w.points[1:])]
            # each behaviour's environment, fetched once (every fetch through navground's binding
            # costs as much as the assignment); the walls never change: given once
            self._envs = [b.environment_state for b in self._behaviours]
            for env in self._envs:
                env.line_obstacles = self._lines
            start = np.array([self.movers[j].position_m for j in self._walkers], dtype=float)
            self._grid = [start]                       # walker positions at grid instants 0, 1, ...
            self._vel = np.zeros_like(start)            # velocity over the current grid step
            self._arrived = np.zeros(len(self._walkers), dtype=bool)
            # track walkers placed on their recording (those there from t = 0 at their first row)
            self._entered = np.array([not hasattr(self.movers[j], "track") or self.movers[j].start_s <= 1e-9
                                      for j in self._walkers], dtype=bool)

    _NAVGROUND = ("_behaviours", "_static_discs", "_lines", "_envs")
    """navground's objects of the walkers (none of them can be copied or pickled)."""

    def __deepcopy__(self, memo):
        """A copy that moves on as this world would: its state copied, navground's objects made
        again (every step sets what they decide from: position, velocity, neighbours, and a track
        walker's target and speed). ``copy.deepcopy`` of a world with walkers failed ("cannot
        pickle 'navground.core._navground.GeometricState'"), and so did that of a Gymnasium
        environment after its reset."""
        import copy
        new = object.__new__(type(self))
        memo[id(self)] = new
        for name, value in self.__dict__.items():
            if name not in self._NAVGROUND:
                setattr(new, name, copy.deepcopy(value, memo))
        if self._walkers:
            from navground import core
            new._behaviours = [_make_behaviour(new.movers[j]) for j in new._walkers]
            new._static_discs = [core.Disc(np.asarray(s.position_m, float), s.radius_m) for s in new._statics]
            new._lines = [core.LineSegment(np.asarray(ln.p1, float), np.asarray(ln.p2, float)) for ln in self._lines]
            new._envs = [b.environment_state for b in new._behaviours]
            for env in new._envs:
                env.line_obstacles = new._lines
        return new

    @property
    def has_walkers(self) -> bool:
        return bool(self._walkers)

    @property
    def advanced_to_s(self) -> float:
        """Until when the walkers' motion is known (inf without walkers)."""
        return (len(self._grid) - 1) * CROWD_TIME_STEP_S if self._walkers else math.inf

    def velocities(self, t_s: float) -> np.ndarray:
        """True velocities ``(n, 2)`` at time ``t_s`` (m/s); for a walker, over the grid step
        that contains ``t_s``."""
        v = np.zeros((self.n, 2))
        for j in self._constant:
            m = self.movers[j]
            _, _, h = m.state_at(t_s)
            v[j] = m.speed_mps * math.cos(float(h)), m.speed_mps * math.sin(float(h))
        for j in self._replay:
            v[j] = self.movers[j].recorded_velocity_at(t_s)
        if self._walkers:
            k = min(int(math.floor(t_s / CROWD_TIME_STEP_S + 1e-9)), len(self._grid) - 2)
            if k >= 0:
                v[self._walkers] = (self._grid[k + 1] - self._grid[k]) / CROWD_TIME_STEP_S
        for j in self._tracked:
            if not self.movers[j].exists_at(t_s):
                v[j] = 0.0
        return v

    def exists(self, t_s: float) -> np.ndarray:
        """Which movers are in the scene at ``t_s``, ``(n,)`` booleans (a mover with a track
        only between its first and last rows)."""
        e = np.ones(self.n, dtype=bool)
        if self._tracked:
            e[self._tracked] = within_window(float(t_s), self._track_start, self._track_end)
        return e

    def positions(self, t_s) -> np.ndarray:
        """True positions at time(s) ``t_s``: shape ``(n, 2)`` for a scalar, ``(len(t), n, 2)``
        for an array. Walkers must have been advanced past the latest time asked."""
        t = np.asarray(t_s, dtype=float)
        ts = np.atleast_1d(t)
        out = np.empty((len(ts), self.n, 2))
        for j in self._constant:
            x, y, _ = self.movers[j].state_at(ts)
            out[:, j, 0], out[:, j, 1] = x, y
        if self._replay:
            # only the replayed tracks that exist at one of the times asked are interpolated (the
            # others are NaN below): a recording's people are in the scene a small part of it
            alive = within_window(ts[:, None], self._replay_start, self._replay_end)     # (len(ts), n_replay)
            for r in np.flatnonzero(alive.any(axis=0)).tolist():
                out[:, self._replay[r], :] = self.movers[self._replay[r]].recorded_at(ts)
        if self._walkers:
            if ts.max(initial=0.0) > self.advanced_to_s + 1e-9:
                raise ValueError(f"walkers known until {self.advanced_to_s:.2f} s, asked for {ts.max():.2f} s")
            grid, last = self._grid, len(self._grid) - 1      # positions at grid instants 0..last
            u = np.clip(ts / CROWD_TIME_STEP_S, 0.0, last)
            k = np.minimum(np.floor(u).astype(int), last - 1) if last > 0 else np.zeros(len(ts), int)
            a = (u - k)[:, None, None]
            # only the rows asked for (stacking the whole history made each call grow with the episode)
            now = np.stack([grid[i] for i in k.tolist()])
            nxt = np.stack([grid[min(i + 1, last)] for i in k.tolist()])
            out[:, self._walkers, :] = (1.0 - a) * now + a * nxt
        if self._tracked:
            gone = ~within_window(ts[:, None], self._track_start, self._track_end)      # (len(ts), n_tracked)
            sub = out[:, self._tracked, :]
            sub[gone] = np.nan
            out[:, self._tracked, :] = sub
        return out if t.ndim else out[0]

    def advance(self, t_end_s: float, robot: RobotMotion | None = None) -> None:
        """Step the walkers until their motion is known at least until ``t_end_s``.

        ``robot(t)`` gives the robot's position and velocity at grid instants up to
        ``t_end_s`` (needed when a walker sees the robot)."""
        if not self._walkers:
            return
        while self.advanced_to_s < t_end_s - 1e-9:
            self._step(robot)

    def _enter(self, row: np.ndarray, before: np.ndarray, t_s: float, robot: RobotMotion | None) -> None:
        """Place the track walkers whose first row falls in the grid step ending at ``t_s`` in
        the walkers' ``row`` of that instant (and in the row ``before`` it, in which they are
        not yet in the scene, so that between the two they are where they entered)."""
        robot_xy = None
        for i, j in enumerate(self._walkers):
            m = self.movers[j]
            if self._entered[i] or m.start_s > t_s + 1e-9:
                continue
            p = m.recorded_at(t_s)     # where its recording is
            if m.sees_robot:
                if robot_xy is None:
                    if robot is None:
                        raise ValueError("a walker that sees the robot needs the robot's motion")
                    robot_xy = np.array(robot(t_s)[:2], dtype=float)
                p = self._beside_robot(m, p, robot_xy)
            row[i] = before[i] = p
            self._entered[i] = True

    def _beside_robot(self, mover, entry: np.ndarray, robot_xy: np.ndarray) -> np.ndarray:
        """Where a walker who sees the robot enters after t = 0: where its recording is, or,
        when that is within :data:`ENTRY_CLEARANCE_M` of the robot's disc, that far from it on the line from
        the robot's centre through the recorded point (from the side it walks in from when the
        point is the robot's centre). Counted: ``entered_beside_robot``."""
        reach = self._robot_radius + float(mover.radius_m) + ENTRY_CLEARANCE_M
        away = entry - robot_xy
        d = math.hypot(*away)
        if d >= reach:
            return entry
        if d < 1e-9:
            v = mover.recorded_velocity_at(mover.start_s)
            away = -v if math.hypot(*v) > 1e-9 else np.array((1.0, 0.0))
            d = math.hypot(*away)
        self.counters["entered_beside_robot"] += 1
        return robot_xy + away * (reach / d)

    def _step(self, robot: RobotMotion | None) -> None:
        from navground import core
        k = len(self._grid) - 1
        t = k * CROWD_TIME_STEP_S
        now = self._grid[-1]
        pos_all = self.positions(t)
        vel_all = self.velocities(t) if k > 0 else np.zeros((self.n, 2))
        if k == 0:
            vel_all[self._walkers] = 0.0
        present = self.exists(t)
        for i, j in enumerate(self._walkers):
            m = self.movers[j]
            if hasattr(m, "track"):
                continue  # follows its recording, has no goal to stand at
            if not self._arrived[i] and math.hypot(*(now[i] - m.goal_m)) <= GOAL_TOLERANCE_M:
                self._arrived[i] = True
                self.counters["arrived"] += 1
        standing = {j for i, j in enumerate(self._walkers) if self._arrived[i]}
        # each mover once, as navground sees it: a walker standing at its goal is a disc (it
        # will not give way), everything else an agent with its velocity
        seen = [None if not present[o] else core.Disc(pos_all[o], float(self.radii[o])) if o in standing
                else core.Neighbor(pos_all[o], float(self.radii[o]), vel_all[o], o) for o in range(self.n)]
        robot_neighbour = None
        if any(self.movers[j].sees_robot for j in self._walkers):
            if robot is None:
                raise ValueError("a walker that sees the robot needs the robot's motion")
            rx, ry, rvx, rvy = robot(t)
            robot_xy = np.array((rx, ry))
            robot_neighbour = core.Neighbor(robot_xy, self._robot_radius, np.array((rvx, rvy)), -1)
        vel = np.zeros_like(now)
        # every walker's centre distance to every mover at once (the same arithmetic, element by
        # element, as one walker's row: NaN for a mover not in the scene, which is never near)
        with np.errstate(invalid="ignore"):
            within = np.hypot(pos_all[None, :, 0] - now[:, None, 0],
                              pos_all[None, :, 1] - now[:, None, 1]) <= PERCEPTION_RANGE_M
        within[np.arange(len(self._walkers)), self._walkers] = False
        stepped = 0
        for i, (j, b, env) in enumerate(zip(self._walkers, self._behaviours, self._envs)):
            if self._arrived[i] or not present[j]:
                continue
            m = self.movers[j]
            if hasattr(m, "track"):
                if not bool(m.exists_at(t + CROWD_TIME_STEP_S)):
                    continue  # leaves the scene at its last row
                target = _aim_at_recording(b, m, now[i], t)
            else:
                target = m.goal_m
            near = np.flatnonzero(within[i]).tolist()
            if standing:
                agents = [seen[o] for o in near if o not in standing]
                discs = [seen[o] for o in near if o in standing]
            else:
                agents, discs = [seen[o] for o in near], []
            if m.sees_robot and math.hypot(*(robot_xy - now[i])) <= PERCEPTION_RANGE_M:
                agents.append(robot_neighbour)
            b.position = now[i]
            b.velocity = self._vel[i]
            env.neighbors = agents
            env.static_obstacles = self._static_discs + discs
            cmd = b.compute_cmd(CROWD_TIME_STEP_S, core.Frame.absolute)
            v = np.asarray(cmd.velocity, dtype=float)
            # never overshoot the goal within one grid step: stop on it
            to_goal = np.asarray(target, dtype=float) - now[i]
            d = math.hypot(*to_goal)
            if math.hypot(*v) * CROWD_TIME_STEP_S > d > 0:
                v = to_goal / CROWD_TIME_STEP_S
            vel[i] = v
            stepped += 1
        self._vel = vel
        following = now + vel * CROWD_TIME_STEP_S
        self._enter(following, now, t + CROWD_TIME_STEP_S, robot)
        self._grid.append(following)
        self.steps += 1
        # the walkers that decided (a track walker outside its window does not: counted, the 415
        # people of a recording made 56 000 steps of an episode's 8 000)
        self.counters["walker_steps"] += stepped


def _make_behaviour(mover):
    """navground's behaviour for one walker: its type, radius, speeds and target."""
    from navground import core
    b = core.Behavior.make_type(BEHAVIOURS[mover.behaviour])
    b.kinematics = core.Kinematics.make_type("Omni")
    if hasattr(mover, "track"):
        top = max(TRACK_SPEED_FACTOR * mover.max_recorded_speed_mps, 0.1)
        b.kinematics.max_speed = b.max_speed = b.optimal_speed = top
        goal = mover.recorded_at(mover.start_s + TRACK_LOOKAHEAD_S)
    else:
        b.kinematics.max_speed = mover.preferred_speed_mps
        b.max_speed = mover.preferred_speed_mps
        b.optimal_speed = mover.preferred_speed_mps
        goal = mover.goal_m
    b.radius = mover.radius_m
    b.safety_margin = MOVER_SAFETY_MARGIN_M
    b.target = core.Target.Point(np.asarray(goal, dtype=float), GOAL_TOLERANCE_M)
    return b


def _aim_at_recording(b, mover, position, t_s: float) -> np.ndarray:
    """Point a track walker's behaviour at where its recording is :data:`TRACK_LOOKAHEAD_S`
    ahead, at the speed that gets it there in that time (within its top speed); that point."""
    from navground import core
    goal = mover.recorded_at(min(t_s + TRACK_LOOKAHEAD_S, mover.end_s))
    speed = min(float(np.hypot(*(goal - position))) / TRACK_LOOKAHEAD_S, b.max_speed)
    b.optimal_speed = max(speed, 1e-3)
    goal = np.asarray(goal, dtype=float)
    b.target = core.Target.Point(goal, GOAL_TOLERANCE_M)
    return goal
