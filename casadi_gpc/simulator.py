"""The closed loop: true obstacle motion, noisy measurements, the controller, exact robot
motion, and the contract's outcome rules (goal, collision, time limit)."""
from __future__ import annotations

import time
from collections import deque
from dataclasses import dataclass, field

import numpy as np

from .robot import RobotState, brake_wheels, robot_step
from .types import ControlDecision, ObstacleMeasurement, Observation, Policy

__all__ = ["RunLog", "simulate", "GOAL_TOLERANCE_M", "SUBSTEPS", "interval_clearances"]

GOAL_TOLERANCE_M = 0.3
SUBSTEPS = 20  # collision-check instants per sample interval (the contract asks for >= 10)


@dataclass
class RunLog:
    """Everything that happened in one episode, sampled at the controller's sample instants."""

    scenario: object
    controller: str
    sample_time_s: float
    t: list = field(default_factory=list)
    states: list = field(default_factory=list)          # (x, y, heading, v_right, v_left) at t
    ref_poses: list = field(default_factory=list)       # nominal reference point at t
    obstacle_xy: list = field(default_factory=list)     # (n_obstacles, 2) true positions at t
    compute_time_s: list = field(default_factory=list)
    decisions: list = field(default_factory=list)
    min_clearance_m: float = float("inf")
    outcome: str = "timed_out"
    end_time_s: float = 0.0
    fallbacks: int = 0
    clipped_commands: int = 0
    events: dict = field(default_factory=dict)


def _all_obstacles(scenario):
    """(radius, position-function) for every obstacle, moving then static."""
    out = [(m.radius_m, (lambda t, m=m: np.stack(m.state_at(t)[:2], axis=-1))) for m in scenario.moving]
    out += [(s.radius_m, (lambda t, s=s: np.broadcast_to(np.asarray(s.position_m, float), np.shape(t) + (2,))))
            for s in scenario.static]
    return out


def interval_clearances(scenario, state: np.ndarray, v_right: float, v_left: float, t0: float, dt: float,
                        substeps: int = SUBSTEPS) -> np.ndarray:
    """Disc-to-disc gaps to every obstacle at ``substeps`` evenly spaced instants inside
    (t0, t0 + dt], shape (substeps, n_obstacles). The arcs are exact."""
    tau = dt * np.arange(1, substeps + 1) / substeps
    x, y, _ = robot_step(np, state[0], state[1], state[2], v_right, v_left, tau, scenario.robot.wheel_base_m)
    gaps = []
    for radius, pos in _all_obstacles(scenario):
        xy = pos(t0 + tau)
        gaps.append(np.hypot(xy[:, 0] - x, xy[:, 1] - y) - radius - scenario.robot.radius_m)
    return np.stack(gaps, axis=1) if gaps else np.full((substeps, 0), np.inf)


class _Sensor:
    """Noisy, possibly faulty position measurements of the moving obstacles."""

    def __init__(self, scenario, rng: np.random.Generator, events: dict):
        self.s, self.rng, self.events = scenario, rng, events
        self.queue: deque = deque()

    def measure(self, t: float) -> tuple[ObstacleMeasurement, ...]:
        s, f, rng = self.s, self.s.faults, self.rng
        out = []
        for i, m in enumerate(s.moving):
            x, y, _ = m.state_at(t)
            z = np.array([x, y]) + rng.normal(0.0, s.sensing.position_noise_std_m, 2)
            if f.outlier_prob and rng.random() < f.outlier_prob:
                a = rng.uniform(0, 2 * np.pi)
                z = z + f.outlier_distance_m * np.array([np.cos(a), np.sin(a)])
                self.events["injected_outliers"] = self.events.get("injected_outliers", 0) + 1
            if f.dropout_prob and rng.random() < f.dropout_prob:
                z = None
                self.events["injected_dropouts"] = self.events.get("injected_dropouts", 0) + 1
            out.append(ObstacleMeasurement(i, None if z is None else (float(z[0]), float(z[1])), m.radius_m))
        self.queue.append(tuple(out))
        if len(self.queue) <= f.delay_steps:
            return tuple(ObstacleMeasurement(i, None, m.radius_m) for i, m in enumerate(s.moving))
        return self.queue.popleft()


def simulate(scenario, controller: Policy, controller_name: str = "") -> RunLog:
    """Run one closed-loop episode of ``scenario`` with ``controller`` (reset first)."""
    T = controller.sample_time_s
    robot = scenario.robot
    rng = np.random.default_rng(scenario.sensing.seed)
    controller.reset()
    if hasattr(controller, "inject_failures"):
        controller.inject_failures(scenario.faults.solver_failure_prob, np.random.default_rng([scenario.sensing.seed, 7]))
    log = RunLog(scenario, controller_name, T)
    sensor = _Sensor(scenario, rng, log.events)
    state = scenario.robot_start.as_array().astype(float)
    state[3:] = 0.0
    ref = scenario.reference
    dv_max = robot.max_step_change_mps(T)
    obstacles = _all_obstacles(scenario)
    n_steps = int(np.floor(scenario.duration_s / T + 1e-9))  # never run past duration_s
    gaps0 = [np.hypot(*(pos(0.0) - state[:2])) - r - robot.radius_m for r, pos in obstacles]
    log.min_clearance_m = float(min(gaps0)) if gaps0 else float("inf")

    def record(t):
        log.t.append(t)
        log.states.append(state.copy())
        log.ref_poses.append(ref.pose_at_time(t))
        log.obstacle_xy.append(np.array([pos(t) for _, pos in obstacles]).reshape(-1, 2))

    record(0.0)
    for k in range(n_steps):
        t = k * T
        obs = Observation(t, RobotState(*state), ref, sensor.measure(t), scenario.static)
        t0 = time.perf_counter()
        dec: ControlDecision = controller.decide(obs)
        log.compute_time_s.append(time.perf_counter() - t0)
        log.decisions.append(dec)
        log.fallbacks += int(dec.fallback)
        cmd = np.array([dec.v_right_mps, dec.v_left_mps], dtype=float)
        if not np.all(np.isfinite(cmd)):
            cmd = np.array(brake_wheels(state[3], state[4], dv_max))
            log.events["non_finite_commands"] = log.events.get("non_finite_commands", 0) + 1
        lim = np.clip(np.clip(cmd, state[3:] - dv_max, state[3:] + dv_max),
                      -robot.max_wheel_speed_mps, robot.max_wheel_speed_mps)
        if np.any(np.abs(lim - cmd) > 1e-9):
            log.clipped_commands += 1
        gaps = interval_clearances(scenario, state, lim[0], lim[1], t, T)
        if gaps.size:
            log.min_clearance_m = min(log.min_clearance_m, float(gaps.min()))
        x, y, h = robot_step(np, state[0], state[1], state[2], lim[0], lim[1], T, robot.wheel_base_m)
        state = np.array([x, y, h, lim[0], lim[1]], dtype=float)
        record(t + T)
        if gaps.size and gaps.min() < 0.0:
            first = int(np.argmax(gaps.min(axis=1) < 0.0))
            log.outcome, log.end_time_s = "collided", t + T * (first + 1) / SUBSTEPS
            break
        end = ref.end_pose
        if (t + T) >= ref.duration_s - 1e-9 and np.hypot(state[0] - end[0], state[1] - end[1]) <= GOAL_TOLERANCE_M:
            log.outcome, log.end_time_s = "reached_goal", t + T
            break
    else:
        log.outcome, log.end_time_s = "timed_out", n_steps * T
    for name, value in getattr(controller, "counters", {}).items():
        if isinstance(value, dict):  # a nested report (e.g. the policy's feature report): flatten it
            for sub, n in value.items():
                log.events[f"{name}.{sub}"] = n
        else:
            log.events[name] = value
    return log
