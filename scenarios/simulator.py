"""The closed loop: true obstacle motion, noisy measurements, the controller, exact robot
motion, and the contract's outcome rules (goal, collision, time limit).

:class:`Episode` is one episode stepped by whoever drives the robot (:func:`simulate` with a
controller, or the Gymnasium environment with an agent's actions); :func:`simulate` runs a
controller through a whole episode."""
from __future__ import annotations

import math
import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from .movers import MoverWorld
from casadi_gpc.geometry import distance_to_segments_m, segments_cross
from casadi_gpc.robot import RobotState, brake_wheels, robot_step
from casadi_gpc.types import ControlDecision, ObstacleMeasurement, Observation, Policy, checked_decision

__all__ = ["RunLog", "Episode", "simulate", "GOAL_TOLERANCE_M", "SUBSTEPS"]

GOAL_TOLERANCE_M = 0.3
SUBSTEPS = 20  # collision-check instants per sample interval (the contract asks for >= 10)
CLIP_TOLERANCE_MPS = 1e-6
"""A command clipped by less than this (m/s) is not counted in ``clipped_commands``: a float32
number's rounding (float32(0.4) is 0.4 + 6e-9) made a controller that keeps to the limits in float32,
as a network does, count every command clipped (the tolerance was 1e-9)."""


@dataclass
class RunLog:
    """Everything that happened in one episode, recorded at the controller's sample instants and,
    last, where it ended (a contact, or ``duration_s`` between samples: :meth:`at_samples`)."""

    scenario: object
    controller: str
    sample_time_s: float
    t: list = field(default_factory=list)
    states: list = field(default_factory=list)          # (x, y, heading, v_right, v_left) at t
    ref_poses: list = field(default_factory=list)       # nominal reference point at t
    obstacle_xy: list = field(default_factory=list)     # (n_obstacles, 2) true positions at t
    compute_time_s: list = field(default_factory=list)
    decisions: list = field(default_factory=list)
    mover_clearance_m: list = field(default_factory=list)
    """Per sample interval: the smallest disc-to-disc gap to any moving obstacle over the
    interval's collision-check instants up to a contact (inf without movers)."""
    mover_sample_clearance_m: list = field(default_factory=list)
    """Per sample interval: the same gap at its end (the next sample, or a contact, or
    ``duration_s``). The danger rate counts those of the intervals that end at a sample
    (:meth:`at_samples`; CONTRACT.md: per sample; a contact is not a sample, as in CrowdNav,
    where a collision step is not counted as danger)."""
    min_clearance_m: float = float("inf")
    outcome: str = "timed_out"
    end_time_s: float = 0.0
    fallbacks: int = 0
    clipped_commands: int = 0
    events: dict = field(default_factory=dict)
    collision: dict | None = None
    """What was hit and how, for a collided episode (:meth:`Episode._collision`)."""

    def at_samples(self) -> np.ndarray:
        """The indices of the records at sample instants: not a collided run's last record (the
        contact, never a sample, even one that falls on a sample instant) nor a run's end cut
        at ``duration_s`` between samples."""
        t = np.asarray(self.t, dtype=float) / self.sample_time_s
        k = np.flatnonzero(np.abs(t - np.round(t)) < 1e-9)
        return k[k < len(self.t) - 1] if self.collision is not None else k


class _Sensor:
    """Noisy, possibly faulty position measurements of the moving obstacles.

    A mover that is not in the scene (a track outside its time), whose centre is beyond
    ``[sensing] range_m`` of the robot's, or whose centre a wall hides from the robot's (the
    line between them crosses a wall) is not in the measurement list at all, as a sensor
    reports only what it sees (the noise is drawn for every mover all the same, so the
    numbers of the others do not depend on who is seen)."""

    def __init__(self, scenario, rng: np.random.Generator, events: dict):
        self.s, self.rng, self.events = scenario, rng, events
        self.queue: deque = deque()
        self.range_m = scenario.sensing.range_m
        segs = [w.segments for w in getattr(scenario, "walls", ())]
        self._wall_segments = np.concatenate(segs) if segs else None  # (m, 2, 2): walls hide what is behind them

    def measure(self, t: float, true_xy: np.ndarray, robot_xy=None) -> tuple[ObstacleMeasurement, ...]:
        s, f, rng = self.s, self.s.faults, self.rng
        out = []
        seen = np.isfinite(true_xy[:, 0])
        if self.range_m is not None and robot_xy is not None:
            with np.errstate(invalid="ignore"):
                seen &= np.hypot(true_xy[:, 0] - robot_xy[0], true_xy[:, 1] - robot_xy[1]) <= self.range_m
        if self._wall_segments is not None and robot_xy is not None:
            seen &= ~_blocked(np.asarray(robot_xy, dtype=float), true_xy, self._wall_segments)
        for i, m in enumerate(s.moving):
            z = np.array(true_xy[i]) + rng.normal(0.0, s.sensing.position_noise_std_m, 2)
            if f.outlier_prob and rng.random() < f.outlier_prob:
                a = rng.uniform(0, 2 * np.pi)
                z = z + f.outlier_distance_m * np.array([np.cos(a), np.sin(a)])
                self.events["injected_outliers"] = self.events.get("injected_outliers", 0) + 1
            if f.dropout_prob and rng.random() < f.dropout_prob:
                z = None
                self.events["injected_dropouts"] = self.events.get("injected_dropouts", 0) + 1
            if seen[i]:
                out.append(ObstacleMeasurement(i, None if z is None else (float(z[0]), float(z[1])), m.radius_m))
            elif np.isfinite(true_xy[i, 0]):  # in the scene, out of range or behind a wall (one not in the
                # scene, a track before its first row or after its last, was counted too until 2026-12-01)
                self.events["unseen_measurements"] = self.events.get("unseen_measurements", 0) + 1
        self.queue.append(tuple(out))
        if len(self.queue) <= f.delay_steps:
            return tuple(ObstacleMeasurement(i, None, m.radius_m) for i, m in enumerate(s.moving))
        return self.queue.popleft()


class Episode:
    """One episode of ``scenario`` at sample time ``sample_time_s``.

    ``observation()`` gives what a controller is told now; ``step(decision)`` applies the
    decision's wheel speeds (clipped to the robot's limits, as the robot would) over one
    sample interval, moves the obstacles, checks for collision at :data:`SUBSTEPS` instants
    inside the interval (exact arcs) and for the goal, and returns the outcome once the
    episode has ended (``None`` while it runs). ``log`` holds everything that happened.
    """

    def __init__(self, scenario, sample_time_s: float, controller_name: str = ""):
        self.scenario = scenario
        self.sample_time_s = T = float(sample_time_s)
        self.log = RunLog(scenario, controller_name, T)
        self.world = MoverWorld(scenario.moving, scenario.static, scenario.robot.radius_m, scenario.walls)
        self._sensor = _Sensor(scenario, np.random.default_rng(scenario.sensing.seed), self.log.events)
        self.state = scenario.robot_start.as_array().astype(float)
        self.state[3:] = 0.0
        self.k = 0
        # the run ends at duration_s (CONTRACT.md): its last interval is cut there when duration_s is not a
        # whole number of samples, the first too in a run shorter than one sample (a decision at t = 0, driven
        # and checked up to duration_s: until 2026-12-02 such a run had none, and a mover that ran through the
        # robot before duration_s left it timed out, its clearance the start's)
        whole = int(np.floor(scenario.duration_s / T + 1e-9))
        self.n_steps = whole + int(scenario.duration_s - whole * T > 1e-9)
        self.done = False
        self._static_xy = np.array([s.position_m for s in scenario.static], dtype=float).reshape(-1, 2)
        self._radii = np.array([m.radius_m for m in scenario.moving] + [s.radius_m for s in scenario.static])
        self._n_moving = len(scenario.moving)
        self._walls = tuple(w.points for w in scenario.walls)
        # every wall's segments in two arrays, and where each wall's start (the gaps measured in one call)
        seg = [w.segments for w in scenario.walls]
        self._wall_ab = np.concatenate(seg) if seg else np.zeros((0, 2, 2))
        self._wall_starts = np.cumsum([0] + [len(x) for x in seg[:-1]]) if seg else np.zeros(0, dtype=int)
        gaps0 = np.concatenate([_absent_far(np.hypot(*(self._obstacles_at(0.0) - self.state[:2]).T) - self._radii
                                             - scenario.robot.radius_m), self._wall_gaps(self.state[None, :2])[0]])
        self.log.min_clearance_m = float(gaps0.min()) if gaps0.size else float("inf")
        self._record(0.0)
        if self.n_steps == 0:
            self._finish("timed_out", 0.0)

    @property
    def t_s(self) -> float:
        return self.k * self.sample_time_s

    def _obstacles_at(self, t) -> np.ndarray:
        """True positions of every obstacle, moving then static: ``(n, 2)`` at a time,
        ``(len(t), n, 2)`` at an array of times."""
        mov = self.world.positions(t)
        stat = np.broadcast_to(self._static_xy, mov.shape[:-2] + self._static_xy.shape)
        return np.concatenate([mov, stat], axis=-2)

    def _record(self, t: float) -> None:
        log = self.log
        log.t.append(t)
        log.states.append(self.state.copy())
        log.ref_poses.append(self.scenario.reference.pose_at_time(t))
        log.obstacle_xy.append(self._obstacles_at(t).reshape(-1, 2))

    def observation(self) -> Observation:
        """What the controller is told at the current sample instant."""
        t = self.t_s
        sc = self.scenario
        moving = self._sensor.measure(t, self.world.positions(t), self.state[:2]) if sc.moving else ()
        return Observation(t, RobotState(*self.state), sc.reference, moving, sc.static, self._walls)

    def _robot_motion(self, state: np.ndarray, wheels: np.ndarray, t0: float):
        """The robot's position and velocity at a time in the coming interval (for walkers
        that see it)."""
        W = self.scenario.robot.wheel_base_m
        speed = 0.5 * (wheels[0] + wheels[1])

        def at(t: float):
            x, y, h = robot_step(math, state[0], state[1], state[2], wheels[0], wheels[1], t - t0, W)
            return x, y, speed * math.cos(h), speed * math.sin(h)
        return at

    def interval_s(self) -> float:
        """The coming interval's length: the sample time, or, for the last one, what is left to
        ``duration_s``."""
        return min(self.sample_time_s, self.scenario.duration_s - self.t_s) if self.k == self.n_steps - 1 \
            else self.sample_time_s

    def interval_clearances(self, wheels: np.ndarray) -> np.ndarray:
        """Gaps to every obstacle at :data:`SUBSTEPS` evenly spaced instants inside the
        coming interval, shape ``(SUBSTEPS, n_obstacles)`` (moving, static, then the walls:
        the robot's disc to the polyline), with the robot driving ``wheels`` (exact arcs)."""
        T, t0, st = self.interval_s(), self.t_s, self.state
        tau = T * np.arange(1, SUBSTEPS + 1) / SUBSTEPS
        x, y, _ = robot_step(np, st[0], st[1], st[2], wheels[0], wheels[1], tau, self.scenario.robot.wheel_base_m)
        xy = self._obstacles_at(t0 + tau)                                   # (S, n, 2)
        discs = _absent_far(np.hypot(xy[..., 0] - x[:, None], xy[..., 1] - y[:, None]) - self._radii
                            - self.scenario.robot.radius_m)
        if not self.scenario.walls:
            return discs
        return np.concatenate([discs, self._wall_gaps(np.stack([x, y], axis=-1))], axis=1)

    def _wall_gaps(self, robot_xy: np.ndarray) -> np.ndarray:
        """Gaps between the robot's disc at ``robot_xy`` (``(S, 2)``) and each wall, ``(S, n_walls)``: each
        wall's :meth:`~scenarios.model.Wall.distance_m` less the radius, every segment measured in one call
        (the same operations; a wall at a time took a map of thousands of walls a call each)."""
        if not self.scenario.walls:
            return np.zeros((len(robot_xy), 0))
        ab = self._wall_ab
        d = distance_to_segments_m(robot_xy, ab[:, 0], ab[:, 1])                  # (S, segments)
        return np.minimum.reduceat(d, self._wall_starts, axis=-1) - self.scenario.robot.radius_m

    def step(self, decision: ControlDecision, compute_time_s: float = 0.0) -> str | None:
        """Apply ``decision`` over one interval; the outcome once the episode has ended."""
        if self.done:
            raise RuntimeError("the episode has ended")
        sc, log, T, t = self.scenario, self.log, self.sample_time_s, self.t_s
        robot = sc.robot
        dv_max = robot.max_step_change_mps(T)
        log.compute_time_s.append(compute_time_s)
        log.decisions.append(decision)
        log.fallbacks += int(decision.fallback)
        cmd = np.array([decision.v_right_mps, decision.v_left_mps], dtype=float)
        if not np.all(np.isfinite(cmd)):
            cmd = np.array(brake_wheels(self.state[3], self.state[4], dv_max))
            log.events["non_finite_commands"] = log.events.get("non_finite_commands", 0) + 1
        lim = np.clip(np.clip(cmd, self.state[3:] - dv_max, self.state[3:] + dv_max),
                      -robot.max_wheel_speed_mps, robot.max_wheel_speed_mps)
        if np.any(np.abs(lim - cmd) > CLIP_TOLERANCE_MPS):
            log.clipped_commands += 1
        L = self.interval_s()  # T, or less for a last interval cut at duration_s
        self.world.advance(t + L, self._robot_motion(self.state, lim, t))
        gaps = self.interval_clearances(lim)
        hit = bool(gaps.size) and gaps.min() < 0.0
        # the episode ends at the first instant with an overlap: nothing after it is measured
        first = int(np.argmax(gaps.min(axis=1) < 0.0)) if hit else SUBSTEPS - 1
        upto = gaps[:first + 1]
        if upto.size:
            log.min_clearance_m = min(log.min_clearance_m, float(upto.min()))
        log.mover_clearance_m.append(float(upto[:, :self._n_moving].min()) if self._n_moving else math.inf)
        log.mover_sample_clearance_m.append(float(upto[-1, :self._n_moving].min()) if self._n_moving else math.inf)
        if hit:  # what was hit and how, from the interval's start
            log.collision = self._collision(first, int(np.argmin(gaps[first])), lim, t, L)
        tau = L * (first + 1) / SUBSTEPS
        x, y, h = robot_step(np, self.state[0], self.state[1], self.state[2], lim[0], lim[1], tau, robot.wheel_base_m)
        self.state = np.array([x, y, h, lim[0], lim[1]], dtype=float)
        self.k += 1
        self._record(t + tau)  # the robot where the episode ends
        if hit:
            return self._finish("collided", t + tau)
        end = sc.reference.end_pose
        if (t + L) >= sc.reference.duration_s - 1e-9 and math.hypot(x - end[0], y - end[1]) <= GOAL_TOLERANCE_M:
            return self._finish("reached_goal", t + L)
        if self.k >= self.n_steps:
            return self._finish("timed_out", t + L)
        return None

    def _collision(self, substep: int, j: int, wheels: np.ndarray, t0: float, interval_s: float) -> dict:
        """What was hit and how, at the first collision-check instant with an overlap
        (CONTRACT.md, RUN.json's ``collision``): the obstacle's kind and index among its kind,
        the time, the robot's velocity component towards the obstacle's centre or the wall's
        nearest point (the point of contact lies on that line), and how long the obstacle had
        existed. Called with :attr:`state` still the interval's start (``t0``). (Until
        2026-11-30 it was called after the state had moved to the interval's end, so the
        robot's position and heading were taken ``substep + 1`` sub-steps past it: the
        direction of the contact, and so the speed towards it, from the wrong place.)"""
        sc, st = self.scenario, self.state
        tau = interval_s * (substep + 1) / SUBSTEPS
        x, y, h = robot_step(math, st[0], st[1], st[2], wheels[0], wheels[1], tau, sc.robot.wheel_base_m)
        v = 0.5 * (wheels[0] + wheels[1])
        t = t0 + tau
        n_discs = len(self._radii)
        # a disc's centre, or a wall's point nearest the robot: the point of contact is on that line
        ox, oy = self._obstacles_at(t)[j] if j < n_discs else sc.walls[j - n_discs].nearest_point((x, y))
        d = math.hypot(ox - x, oy - y)
        towards = v * (math.cos(h) * (ox - x) + math.sin(h) * (oy - y)) / d if d > 0 else abs(v)
        if j < self._n_moving:
            kind, index = "moving", j
            mover = sc.moving[j]
            age = t - mover.start_s if hasattr(mover, "track") else t
        elif j < n_discs:
            kind, index, age = "static", j - self._n_moving, t
        else:
            kind, index, age = "wall", j - n_discs, t
        return {"obstacle": kind, "index": index, "time_s": t, "robot_speed_towards_mps": towards,
                "obstacle_age_s": age}

    def _finish(self, outcome: str, end_time_s: float) -> str:
        self.log.outcome, self.log.end_time_s = outcome, end_time_s
        self.done = True
        for name, n in self.world.counters.items():
            if n:
                self.log.events[f"movers.{name}"] = n
        return outcome


def _blocked(p: np.ndarray, q: np.ndarray, segments: np.ndarray) -> np.ndarray:
    """Whether the line from ``p`` (2,) to each point of ``q`` (n, 2) crosses one of the
    ``segments`` (m, 2, 2) (touching counts)."""
    return segments_cross(np.broadcast_to(p, q.shape), q, segments[:, 0], segments[:, 1]).any(axis=1)


def _absent_far(gaps: np.ndarray) -> np.ndarray:
    """Gaps to movers that are not in the scene (NaN positions) read as infinitely far."""
    return np.where(np.isnan(gaps), np.inf, gaps) if np.isnan(gaps).any() else gaps


def simulate(scenario, controller: Policy, controller_name: str = "", progress=None) -> RunLog:
    """Run one closed-loop episode of ``scenario`` with ``controller`` (reset first);
    ``progress``: an optional ``tqdm``-like factory ``progress(total=, unit=)``, a bar over the
    episode's samples."""
    controller.reset()
    # a controller with no solver to fail (a network, a peer; a check layer in front of one:
    # its inject_failures answers False) is said to in the events when failures are asked for
    inject = getattr(controller, "inject_failures", None)
    taken = inject is not None and inject(scenario.faults.solver_failure_prob,
                                          np.random.default_rng([scenario.sensing.seed, 7])) is not False
    unapplied = int(not taken and scenario.faults.solver_failure_prob > 0)
    episode = Episode(scenario, controller.sample_time_s, controller_name)
    bar = progress(total=episode.n_steps, unit="step") if progress else None
    while not episode.done:
        obs = episode.observation()
        t0 = time.perf_counter()
        decision = checked_decision(controller.decide(obs), controller)
        episode.step(decision, time.perf_counter() - t0)
        if bar is not None:
            bar.update(1)
    if bar is not None:  # an episode that ended before its time limit: the bar ends full
        bar.total = bar.n
        bar.close()
    log = episode.log
    if unapplied:
        log.events["solver_failures_not_applied"] = 1
    for name, value in getattr(controller, "counters", {}).items():
        if isinstance(value, dict):  # a nested report (e.g. the policy's feature report): flatten it
            for sub, n in value.items():
                log.events[f"{name}.{sub}"] = n
        else:
            log.events[name] = value
    return log
