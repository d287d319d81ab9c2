"""Random driving situations for labelling, seeded, as the planner would see them.

A situation is drawn as the tail of an episode: a reference path, a few samples of robot
and obstacle history, and the robot's state now. The observations of that history are fed
to the deployed policy's own :class:`~nn_export.runtime.tracker.SituationTracker` (the obstacle
EKF and the reference clock of the preset), so the obstacle estimates and covariances, and
the desired poses, are exactly what the GPC and the deployed network would have at that
instant. Numpy only.

Distributions (every number is a field of :class:`SamplerSettings`; U = uniform):

Reference (``reference_mode``):
  - speed U(0.15, 0.6) m/s.
  - path mode (80 %): the current piece is straight (1/2) or an arc of radius U(2, 10) m
    turning either way; with probability 1/2 the curvature changes (to a line or another
    arc, drawn the same way) at U(0, 1) times the distance the reference covers in one
    horizon ahead of the reference point; with probability 0.1 the path ends within
    U(0, 1.2) horizons (the desired points bunch up at the goal).
  - rollout mode (20 %): the desired poses are the robot's own rollout under a smooth
    random wheel plan (target speed U(0.1, 0.6) m/s, target turn rate N(0, 0.3) rad/s
    varying by N(0, 0.15) rad/s per step, within the wheel limits): the second pass of
    the paper's scheme, where the network's predicted path is the new desired trajectory.
  - the reference point is at the time of sample n_now = (obstacle history length - 1)
    + U{0, 1, 2}, with the reference clock of the preset run from t = 0; the robot is on
    the path at the nominal reference point at every earlier sample.
Robot, relative to the nominal reference point (tangent frame):
  - tracking (70 %): lag along the path U(-0.2, 0.6) m, lateral N(0, 0.15) m, heading error
    N(0, 0.15) rad; recovering (30 %): lag U(-0.5, 1.5) m, lateral U(-1.2, 1.2) m, heading
    error U(-0.8, 0.8) rad.
  - previous wheel speeds: at rest (5 %), else forward speed U(0.2, 1.3) times the
    reference speed and turn rate (speed x path curvature + N(0, 0.2) rad/s), clipped to
    the wheel limits.
Moving obstacles (``paper``: none with probability 0.15, else one; ``multi``: 0-3 with
probabilities 0.1, 0.4, 0.25, 0.25):
  - conflict course (65 %): it would pass within U(-0.4, 0.4) m (lateral) of the desired
    point at a time U(0.5 T, H T) ahead, i.e. within the horizon, coming from a direction
    U(30, 330) deg off the path's tangent there (85 %) or U(-30, 30) deg (15 %: same
    direction, overtaking or overtaken); otherwise (35 %) anywhere U(0.6, 10) m from the
    robot with a uniform heading.
  - speed 0 (10 %) or U(0.05, 0.6) m/s; turn rate 0 (60 %) or U(-0.25, 0.25) rad/s;
    radius U(0.2, 0.4) m (the random suite's range).
  - measured on the last n_past samples, n_past = 1 (5 %: a new track, speed unknown) or
    U{2..8}; each measurement has N(0, 0.02 m) noise per axis (the scenario default) and
    is missing with probability 0.03.
Static obstacles (``multi`` only; 0-3 with probabilities 0.4, 0.2, 0.2, 0.2): beside the
path ahead (60 %: U(0, 1) horizon ahead, offset +-U(0, 1.5) m) or anywhere U(1, 8) m from
the robot; radius U(0.15, 0.35) m.
Rejected and redrawn: any obstacle whose disc is within 0.1 m of the robot's now, or
farther than 11 m (inside the features' 12 m range).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.ekf import EKFSettings
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState, arc_step, robot_step
from casadi_gpc.types import Observation, ObstacleMeasurement, StaticObstacle

from ..runtime.situation import Situation
from ..runtime.tracker import SituationTracker

__all__ = ["SamplerSettings", "sample_situation", "situation_stream", "episode_tail", "situation_from_tail",
           "EpisodeTail"]


@dataclass(frozen=True)
class SamplerSettings:
    """The distributions of :func:`sample_situation` (see the module docstring)."""

    ref_speed_mps: tuple[float, float] = (0.15, 0.6)
    p_rollout_reference: float = 0.2
    """Share of situations whose desired trajectory is a robot rollout (the second pass)."""
    p_straight: float = 0.5
    arc_radius_m: tuple[float, float] = (2.0, 10.0)
    p_curvature_change: float = 0.5
    p_path_end: float = 0.1
    p_tracking: float = 0.7
    """Share of robots close to the reference; the rest are recovering from a detour."""
    p_at_rest: float = 0.05
    moving_counts_paper: tuple[float, ...] = (0.15, 0.85)
    moving_counts_multi: tuple[float, ...] = (0.1, 0.4, 0.25, 0.25)
    static_counts_multi: tuple[float, ...] = (0.4, 0.2, 0.2, 0.2)
    p_conflict: float = 0.65
    """Share of moving obstacles on a conflict course within the horizon."""
    p_same_direction: float = 0.15
    conflict_lateral_m: float = 0.4
    obstacle_speed_mps: tuple[float, float] = (0.05, 0.6)
    p_standing: float = 0.1
    p_turning: float = 0.4
    turn_rate_rad_s: float = 0.25
    obstacle_radius_m: tuple[float, float] = (0.2, 0.4)
    static_radius_m: tuple[float, float] = (0.15, 0.35)
    max_history: int = 8
    p_new_track: float = 0.05
    measurement_std_m: float = 0.02
    p_missing: float = 0.03
    min_clearance_m: float = 0.1
    max_distance_m: float = 11.0


@dataclass(frozen=True)
class _Mover:
    position_m: tuple[float, float]
    heading_rad: float
    speed_mps: float
    turn_rate_rad_s: float
    radius_m: float

    def at(self, dt_s: float) -> tuple[float, float]:
        x, y, _ = arc_step(np, self.position_m[0], self.position_m[1], self.heading_rad, self.speed_mps,
                           self.turn_rate_rad_s, dt_s)
        return float(x), float(y)


@dataclass(frozen=True)
class EpisodeTail:
    """The sampled history that a situation is the end of: replaying ``observations`` through
    a fresh :class:`SituationTracker` gives the situation (before any rollout reference)."""

    observations: tuple[Observation, ...]
    movers: tuple[_Mover, ...]
    """True obstacle motions (positions now, at the last observation)."""
    rollout_ref: np.ndarray | None
    """Desired poses (H+1, 3) replacing the path's, in rollout mode."""
    rollout_speed_mps: float = float("nan")


def _choice(rng, probs) -> int:
    """An index drawn with probabilities ``probs`` (normalised)."""
    c = np.cumsum(probs)
    return min(int(np.searchsorted(c, rng.random() * c[-1], side="right")), len(probs) - 1)


def _curvature(rng, st: SamplerSettings) -> float:
    if rng.random() < st.p_straight:
        return 0.0
    return float(rng.choice([-1.0, 1.0]) / rng.uniform(*st.arc_radius_m))


def _rollout(rng, robot: RobotParams, state: np.ndarray, H: int, T: float) -> tuple[np.ndarray, float]:
    """Poses at steps 0..H of the robot under a smooth random wheel plan within the limits."""
    W, vmax, dv = robot.wheel_base_m, robot.max_wheel_speed_mps, robot.max_step_change_mps(T)
    v_t, w_t = rng.uniform(0.1, 0.6), rng.normal(0.0, 0.3)
    x, y, h, vr, vl = (float(a) for a in state)
    poses, speeds = [(x, y, h)], []
    for _ in range(H):
        w_t += rng.normal(0.0, 0.15)
        target = np.array([v_t + 0.5 * w_t * W, v_t - 0.5 * w_t * W])
        wheels = np.clip(np.clip(target, [vr - dv, vl - dv], [vr + dv, vl + dv]), -vmax, vmax)
        vr, vl = float(wheels[0]), float(wheels[1])
        x, y, h = (float(a) for a in robot_step(np, x, y, h, vr, vl, T, W))
        poses.append((x, y, h))
        speeds.append(0.5 * (vr + vl))
    return np.array(poses), float(np.mean(speeds))


def episode_tail(rng: np.random.Generator, config: PlannerConfig, layout_name: str = "paper",
                 robot: RobotParams | None = None, settings: SamplerSettings | None = None) -> EpisodeTail:
    """Draw the history of one situation (see the module docstring for the distributions)."""
    st = settings or SamplerSettings()
    robot = robot or RobotParams()
    H, T = config.horizon, config.sample_time_s
    W, vmax = robot.wheel_base_m, robot.max_wheel_speed_mps

    # --- obstacles' counts and histories first: they fix how long the tail is
    if layout_name == "paper":
        n_moving, n_static = _choice(rng, st.moving_counts_paper), 0
    else:
        n_moving, n_static = _choice(rng, st.moving_counts_multi), _choice(rng, st.static_counts_multi)
    n_past = [1 if rng.random() < st.p_new_track else int(rng.integers(2, st.max_history + 1))
              for _ in range(n_moving)]
    n_now = max(n_past, default=1) - 1 + int(rng.integers(0, 3))
    t_now = n_now * T

    # --- the reference path, long enough behind the reference point and ahead of it
    v_ref = float(rng.uniform(*st.ref_speed_mps))
    s_nom = v_ref * t_now
    reach = v_ref * H * T
    k1 = _curvature(rng, st)
    if rng.random() < st.p_curvature_change:
        first = s_nom + rng.uniform(0.0, 1.0) * reach
        segs = [Segment(max(first, 1e-3), k1), Segment(2.0 * reach + 5.0, _curvature(rng, st))]
    else:
        segs = [Segment(s_nom + 2.0 * reach + 5.0, k1)]
    if rng.random() < st.p_path_end:
        end = s_nom + rng.uniform(0.0, 1.2) * reach
        total, kept = 0.0, []
        for seg in segs:
            take = min(seg.length_m, end - total)
            if take > 1e-3:
                kept.append(Segment(take, seg.curvature_1pm))
            total += take
        segs = kept or [Segment(max(end, 1e-3), k1)]
    path = ReferencePath((0.0, 0.0), 0.0, tuple(segs), v_ref)

    # --- the robot now, relative to the nominal reference point
    px, py, ph = (float(a) for a in path.pose_at_arclength(s_nom))
    if rng.random() < st.p_tracking:
        lag, lat, dh = rng.uniform(-0.2, 0.6), rng.normal(0.0, 0.15), rng.normal(0.0, 0.15)
    else:
        lag, lat, dh = rng.uniform(-0.5, 1.5), rng.uniform(-1.2, 1.2), rng.uniform(-0.8, 0.8)
    c, s = math.cos(ph), math.sin(ph)
    rx, ry, rh = px - lag * c - lat * s, py - lag * s + lat * c, ph + dh
    if rng.random() < st.p_at_rest:
        vr = vl = 0.0
    else:
        v = v_ref * rng.uniform(0.2, 1.3)
        w = v * float(path.curvature_at_arclength(s_nom)) + rng.normal(0.0, 0.2)
        vr, vl = (float(np.clip(a, -vmax, vmax)) for a in (v + 0.5 * w * W, v - 0.5 * w * W))
    robot_now = RobotState(rx, ry, rh, vr, vl)

    rollout_ref, rollout_speed = None, float("nan")
    if rng.random() < st.p_rollout_reference:
        rollout_ref, rollout_speed = _rollout(rng, robot, robot_now.as_array(), H, T)

    def desired_at(t_ahead: float) -> tuple[float, float, float]:
        """Where the desired trajectory is ``t_ahead`` seconds from now."""
        if rollout_ref is not None:
            j = min(max(t_ahead / T, 0.0), float(H))
            i = min(int(j), H - 1)
            a = j - i
            p = (1 - a) * rollout_ref[i] + a * rollout_ref[i + 1]
            return float(p[0]), float(p[1]), float(p[2])
        return tuple(float(v) for v in path.pose_at_arclength(s_nom + v_ref * t_ahead))

    def clear_of_robot(xy, radius) -> bool:
        d = math.hypot(xy[0] - rx, xy[1] - ry)
        return d - radius - robot.radius_m >= st.min_clearance_m and d <= st.max_distance_m

    # --- moving obstacles
    movers = []
    for _ in range(n_moving):
        for _attempt in range(1000):
            speed = 0.0 if rng.random() < st.p_standing else float(rng.uniform(*st.obstacle_speed_mps))
            turn = float(rng.uniform(-st.turn_rate_rad_s, st.turn_rate_rad_s)) if rng.random() < st.p_turning else 0.0
            radius = float(rng.uniform(*st.obstacle_radius_m))
            if rng.random() < st.p_conflict:
                t_c = float(rng.uniform(0.5 * T, H * T))
                cx, cy, ch = desired_at(t_c)
                off = float(rng.uniform(-st.conflict_lateral_m, st.conflict_lateral_m))
                cx, cy = cx - off * math.sin(ch), cy + off * math.cos(ch)
                if rng.random() < st.p_same_direction:
                    rel = math.radians(rng.uniform(-30.0, 30.0))
                else:
                    rel = math.radians(rng.uniform(30.0, 330.0))
                head_c = ch + rel
                # run the obstacle's exact arc backwards from the conflict point to now
                x0, y0, h0 = arc_step(np, cx, cy, head_c, speed, turn, -t_c)
                m = _Mover((float(x0), float(y0)), float(h0), speed, turn, radius)
            else:
                d = float(rng.uniform(0.6, 10.0))
                a = float(rng.uniform(0.0, 2 * math.pi))
                m = _Mover((rx + d * math.cos(a), ry + d * math.sin(a)), float(rng.uniform(0, 2 * math.pi)),
                           speed, turn, radius)
            if clear_of_robot(m.position_m, radius):
                movers.append(m)
                break
        else:  # pragma: no cover - the placement region is never empty
            raise RuntimeError("could not place a moving obstacle")

    # --- static obstacles
    statics = []
    for _ in range(n_static):
        for _attempt in range(1000):
            radius = float(rng.uniform(*st.static_radius_m))
            if rng.random() < 0.6:
                x, y, h = desired_at(float(rng.uniform(0.0, 1.0)) * H * T)
                off = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.0, 1.5))
                xy = (x - off * math.sin(h), y + off * math.cos(h))
            else:
                d, a = float(rng.uniform(1.0, 8.0)), float(rng.uniform(0.0, 2 * math.pi))
                xy = (rx + d * math.cos(a), ry + d * math.sin(a))
            if clear_of_robot(xy, radius):
                statics.append(StaticObstacle((float(xy[0]), float(xy[1])), radius))
                break
        else:  # pragma: no cover
            raise RuntimeError("could not place a static obstacle")

    # --- the observation history, samples 0..n_now (positions computed per track at once)
    hist_poses = path.pose_at_arclength(v_ref * T * np.arange(n_now)) if n_now else np.zeros((0, 3))
    v_mean = 0.5 * (vr + vl)
    first = [n_now - n + 1 for n in n_past]  # the sample at which each obstacle is first measured
    z = []
    for j, m in enumerate(movers):
        dt = T * (np.arange(first[j], n_now + 1) - n_now)
        x, y, _ = arc_step(np, m.position_m[0], m.position_m[1], m.heading_rad, m.speed_mps, m.turn_rate_rad_s, dt)
        zj = np.stack([x, y], axis=1) + rng.normal(0.0, st.measurement_std_m, (n_past[j], 2))
        zj[rng.random(n_past[j]) < st.p_missing] = np.nan
        z.append(zj)
    observations = []
    statics = tuple(statics)
    for k in range(n_now + 1):
        if k < n_now:
            r_k = RobotState(float(hist_poses[k, 0]), float(hist_poses[k, 1]), float(hist_poses[k, 2]), v_mean, v_mean)
        else:
            r_k = robot_now
        meas = []
        for j, m in enumerate(movers):
            if k >= first[j]:
                zk = z[j][k - first[j]]
                pos = None if np.isnan(zk[0]) else (float(zk[0]), float(zk[1]))
                meas.append(ObstacleMeasurement(j, pos, m.radius_m))
        observations.append(Observation(k * T, r_k, path, tuple(meas), statics))
    return EpisodeTail(tuple(observations), tuple(movers), rollout_ref, rollout_speed)


def situation_from_tail(tail: EpisodeTail, config: PlannerConfig, ekf_settings: EKFSettings | None = None,
                        tracker: SituationTracker | None = None) -> Situation:
    """Replay the tail through a (fresh or reset) :class:`SituationTracker`."""
    tracker = tracker or SituationTracker(config, ekf_settings)
    tracker.reset()
    for obs in tail.observations[:-1]:
        tracker.observe(obs)
    sit = tracker.update(tail.observations[-1])
    if tail.rollout_ref is not None:
        sit = replace(sit.with_reference(tail.rollout_ref), ref_speed_mps=tail.rollout_speed_mps)
    return sit


def sample_situation(rng: np.random.Generator, config: PlannerConfig, layout_name: str = "paper",
                     robot: RobotParams | None = None, settings: SamplerSettings | None = None,
                     tracker: SituationTracker | None = None) -> Situation:
    """One random situation as the planner would see it (``info`` holds the tail)."""
    tail = episode_tail(rng, config, layout_name, robot, settings)
    sit = situation_from_tail(tail, config, tracker=tracker)
    sit.info["tail"] = tail
    return sit


def situation_stream(seed, config: PlannerConfig, layout_name: str = "paper", robot: RobotParams | None = None,
                     settings: SamplerSettings | None = None):
    """An endless, reproducible stream of situations from ``seed`` (an int or a sequence)."""
    rng = np.random.default_rng(seed)
    tracker = SituationTracker(config)
    while True:
        yield sample_situation(rng, config, layout_name, robot, settings, tracker)
