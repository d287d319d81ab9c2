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

The paper's two passes (``first_pass``, :mod:`nn_export.training.two_pass`): the path and
the robot are drawn as above, then the desired trajectory is the first pass's prediction
(given by the caller for the obstacle-free tail), and one moving obstacle (``paper``) is
drawn against it as above but within U(-1.6, 1.6) m of the desired point, kept only if it
comes within 1.25 m (clearance) of the desired path at the same step within the horizon:
the situations in which the deployed policy runs its second pass (1.0 m, with a margin).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.estimation.ekf import EKFSettings
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState, arc_step, robot_step
from casadi_gpc.types import Observation, ObstacleMeasurement, StaticObstacle

from ..runtime.situation import Situation
from ..runtime.tracker import SituationTracker
from .sampler_settings import SamplerSettings

__all__ = ["SamplerSettings", "sample_situation", "situation_stream", "episode_tail", "situation_from_tail",
           "EpisodeTail"]


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


def _rollout(rng, st: SamplerSettings, robot: RobotParams, state: np.ndarray, H: int, T: float
             ) -> tuple[np.ndarray, float]:
    """Poses at steps 0..H of the robot under a smooth random wheel plan within the limits."""
    W, vmax, dv = robot.wheel_base_m, robot.max_wheel_speed_mps, robot.max_step_change_mps(T)
    v_t, w_t = rng.uniform(*st.rollout_speed_mps), rng.normal(0.0, st.rollout_turn_rate_std_rad_s)
    x, y, h, vr, vl = (float(a) for a in state)
    poses, speeds = [(x, y, h)], []
    for _ in range(H):
        w_t += rng.normal(0.0, st.rollout_turn_rate_walk_rad_s)
        target = np.array([v_t + 0.5 * w_t * W, v_t - 0.5 * w_t * W])
        wheels = np.clip(np.clip(target, [vr - dv, vl - dv], [vr + dv, vl + dv]), -vmax, vmax)
        vr, vl = float(wheels[0]), float(wheels[1])
        x, y, h = (float(a) for a in robot_step(np, x, y, h, vr, vl, T, W))
        poses.append((x, y, h))
        speeds.append(0.5 * (vr + vl))
    return np.array(poses), float(np.mean(speeds))


def episode_tail(rng: np.random.Generator, config: PlannerConfig, layout_name: str = "paper",
                 robot: RobotParams | None = None, settings: SamplerSettings | None = None,
                 first_pass=None) -> EpisodeTail:
    """Draw the history of one situation (see the module docstring for the distributions).

    The steps draw from ``rng`` in this order, which fixes every situation of a seed: the
    obstacle counts and history lengths, the reference path, the robot now, the rollout
    reference, the moving obstacles, the static ones, the measurements.

    ``first_pass``: the paper's second pass. A callable given the obstacle-free tail (same
    path, robot, history) and ``second_pass_reference`` that returns the first pass's
    prediction: the desired poses at steps 0..H, shape (H+1, 3), step 0 the robot's pose,
    and their mean speed. The obstacle is drawn against that path; no rollout reference."""
    st = settings or SamplerSettings()
    robot = robot or RobotParams()
    H, T = config.horizon, config.sample_time_s
    counts = st.moving_counts_second_pass if first_pass is not None else None
    n_moving, n_static, n_past, n_now = _counts(rng, st, layout_name, counts)
    v_ref = float(rng.uniform(*st.ref_speed_mps))
    s_nom = v_ref * (n_now * T)
    path = _reference_path(rng, st, v_ref, s_nom, v_ref * H * T)
    robot_now = _robot_now(rng, st, robot, path, s_nom)
    rollout_ref, rollout_speed = None, float("nan")
    lateral, near = st.conflict_lateral_m, None
    if first_pass is not None:
        free = EpisodeTail(_history(rng, st, path, T, n_now, [], robot_now, (), ()), (), None)
        rollout_ref, rollout_speed = first_pass(free, st.second_pass_reference)
        lateral, near = st.second_pass_lateral_m, _near_path(rollout_ref, robot, st.second_pass_max_clearance_m, T)
    elif rng.random() < st.p_rollout_reference:
        rollout_ref, rollout_speed = _rollout(rng, st, robot, robot_now.as_array(), H, T)
    desired = _Desired(path, s_nom, rollout_ref, H, T)
    movers = tuple(_place(rng, st, robot, robot_now, lambda: _draw_mover(rng, st, desired, robot_now, lateral),
                          "a moving", near) for _ in range(n_moving))
    statics = tuple(_place(rng, st, robot, robot_now, lambda: _draw_static(rng, st, desired, robot_now), "a static")
                    for _ in range(n_static))
    observations = _history(rng, st, path, T, n_now, n_past, robot_now, movers, statics)
    return EpisodeTail(observations, movers, rollout_ref, rollout_speed)


def _counts(rng, st: SamplerSettings, layout_name: str, moving_counts=None) -> tuple[int, int, list[int], int]:
    """How many moving and static obstacles, each moving one's history length, and the
    sample of now: the obstacles' histories fix how long the tail is."""
    if layout_name == "paper":
        n_moving, n_static = _choice(rng, moving_counts or st.moving_counts_paper), 0
    else:
        n_moving, n_static = _choice(rng, st.moving_counts_multi), _choice(rng, st.static_counts_multi)
    n_past = [1 if rng.random() < st.p_new_track else int(rng.integers(st.min_history, st.max_history + 1))
              for _ in range(n_moving)]
    n_now = max(n_past, default=1) - 1 + int(rng.integers(0, st.extra_history_samples + 1))
    return n_moving, n_static, n_past, n_now


def _reference_path(rng, st: SamplerSettings, v_ref: float, s_nom: float, reach: float) -> ReferencePath:
    """The reference path, long enough behind the reference point (at ``s_nom``) and ahead of
    it; ``reach``: the reference's travel in one horizon, m."""
    k1 = _curvature(rng, st)
    if rng.random() < st.p_curvature_change:
        first = s_nom + rng.uniform(*st.curvature_change_horizons) * reach
        segs = [Segment(max(first, 1e-3), k1),
                Segment(st.path_ahead_horizons * reach + st.path_ahead_margin_m, _curvature(rng, st))]
    else:
        segs = [Segment(s_nom + st.path_ahead_horizons * reach + st.path_ahead_margin_m, k1)]
    if rng.random() < st.p_path_end:
        end = s_nom + rng.uniform(*st.path_end_horizons) * reach
        total, kept = 0.0, []
        for seg in segs:
            take = min(seg.length_m, end - total)
            if take > 1e-3:
                kept.append(Segment(take, seg.curvature_1pm))
            total += take
        segs = kept or [Segment(max(end, 1e-3), k1)]
    return ReferencePath((0.0, 0.0), 0.0, tuple(segs), v_ref)


def _robot_now(rng, st: SamplerSettings, robot: RobotParams, path: ReferencePath, s_nom: float) -> RobotState:
    """The robot now, placed relative to the nominal reference point (tangent frame), with
    the wheel speeds it drove with."""
    px, py, ph = (float(a) for a in path.pose_at_arclength(s_nom))
    if rng.random() < st.p_tracking:
        lag, lat, dh = (rng.uniform(*st.tracking_lag_m), rng.normal(0.0, st.tracking_lateral_std_m),
                        rng.normal(0.0, st.tracking_heading_std_rad))
    else:
        lag, lat, dh = (rng.uniform(*st.recovering_lag_m), rng.uniform(*st.recovering_lateral_m),
                        rng.uniform(*st.recovering_heading_rad))
    c, s = math.cos(ph), math.sin(ph)
    W, vmax = robot.wheel_base_m, robot.max_wheel_speed_mps
    if rng.random() < st.p_at_rest:
        vr = vl = 0.0
    else:
        v = path.speed_mps * rng.uniform(*st.speed_ratio)
        w = v * float(path.curvature_at_arclength(s_nom)) + rng.normal(0.0, st.turn_rate_std_rad_s)
        vr, vl = (float(np.clip(a, -vmax, vmax)) for a in (v + 0.5 * w * W, v - 0.5 * w * W))
    return RobotState(px - lag * c - lat * s, py - lag * s + lat * c, ph + dh, vr, vl)


@dataclass(frozen=True)
class _Desired:
    """The desired trajectory from now: the path's (from the reference point at ``s_nom``)
    or, in rollout mode, the rollout's poses at steps 0..H, linear between them."""

    path: ReferencePath
    s_nom: float
    rollout_ref: np.ndarray | None
    horizon: int
    sample_time_s: float

    def at(self, t_ahead: float) -> tuple[float, float, float]:
        """Where the desired trajectory is ``t_ahead`` seconds from now."""
        H, T = self.horizon, self.sample_time_s
        if self.rollout_ref is not None:
            j = min(max(t_ahead / T, 0.0), float(H))
            i = min(int(j), H - 1)
            a = j - i
            p = (1 - a) * self.rollout_ref[i] + a * self.rollout_ref[i + 1]
            return float(p[0]), float(p[1]), float(p[2])
        return tuple(float(v) for v in self.path.pose_at_arclength(self.s_nom + self.path.speed_mps * t_ahead))


def _near_path(poses: np.ndarray, robot: RobotParams, clearance_m: float, T: float):
    """Whether a mover comes within ``clearance_m`` of the desired poses (steps 1..H) at the same step."""
    def near(m: _Mover) -> bool:
        x, y, _ = arc_step(np, m.position_m[0], m.position_m[1], m.heading_rad, m.speed_mps, m.turn_rate_rad_s,
                           T * np.arange(1, len(poses)))
        d = np.hypot(x - poses[1:, 0], y - poses[1:, 1]) - robot.radius_m - m.radius_m
        return bool(np.min(d) <= clearance_m)
    return near


def _place(rng, st: SamplerSettings, robot: RobotParams, robot_now: RobotState, draw, what: str, accept=None):
    """``draw()`` until the obstacle it gives is clear of the robot now, within range, and
    ``accept``-ed (if given)."""
    for _attempt in range(1000):
        obstacle = draw()
        (x, y), radius = obstacle.position_m, obstacle.radius_m
        d = math.hypot(x - robot_now.x_m, y - robot_now.y_m)
        if (d - radius - robot.radius_m >= st.min_clearance_m and d <= st.max_distance_m
                and (accept is None or accept(obstacle))):
            return obstacle
    raise RuntimeError(f"could not place {what} obstacle")  # pragma: no cover - the region is never empty


def _draw_mover(rng, st: SamplerSettings, desired: _Desired, robot_now: RobotState, lateral_m: float) -> _Mover:
    """A moving obstacle: on a conflict course within the horizon (within +-``lateral_m`` of
    the desired point), or anywhere around."""
    speed = 0.0 if rng.random() < st.p_standing else float(rng.uniform(*st.obstacle_speed_mps))
    turn = float(rng.uniform(-st.turn_rate_rad_s, st.turn_rate_rad_s)) if rng.random() < st.p_turning else 0.0
    radius = float(rng.uniform(*st.obstacle_radius_m))
    if rng.random() < st.p_conflict:
        T = desired.sample_time_s
        t_c = float(rng.uniform(st.conflict_first_step * T, desired.horizon * T))
        cx, cy, ch = desired.at(t_c)
        off = float(rng.uniform(-lateral_m, lateral_m))
        cx, cy = cx - off * math.sin(ch), cy + off * math.cos(ch)
        cone = st.same_direction_deg
        if rng.random() < st.p_same_direction:
            rel = math.radians(rng.uniform(-cone, cone))
        else:
            rel = math.radians(rng.uniform(cone, 360.0 - cone))
        # run the obstacle's exact arc backwards from the conflict point to now
        x0, y0, h0 = arc_step(np, cx, cy, ch + rel, speed, turn, -t_c)
        return _Mover((float(x0), float(y0)), float(h0), speed, turn, radius)
    d = float(rng.uniform(*st.free_distance_m))
    a = float(rng.uniform(0.0, 2 * math.pi))
    return _Mover((robot_now.x_m + d * math.cos(a), robot_now.y_m + d * math.sin(a)),
                  float(rng.uniform(0, 2 * math.pi)), speed, turn, radius)


def _draw_static(rng, st: SamplerSettings, desired: _Desired, robot_now: RobotState) -> StaticObstacle:
    """A static obstacle: beside the desired path ahead, or anywhere around."""
    radius = float(rng.uniform(*st.static_radius_m))
    if rng.random() < st.p_static_beside_path:
        x, y, h = desired.at(float(rng.uniform(*st.static_ahead_horizons)) * desired.horizon * desired.sample_time_s)
        off = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.0, st.static_offset_m))
        xy = (x - off * math.sin(h), y + off * math.cos(h))
    else:
        d, a = float(rng.uniform(*st.static_distance_m)), float(rng.uniform(0.0, 2 * math.pi))
        xy = (robot_now.x_m + d * math.cos(a), robot_now.y_m + d * math.sin(a))
    return StaticObstacle((float(xy[0]), float(xy[1])), radius)


def _history(rng, st: SamplerSettings, path: ReferencePath, T: float, n_now: int, n_past: list[int],
             robot_now: RobotState, movers, statics) -> tuple[Observation, ...]:
    """The observations at samples 0..n_now: the robot on the path at the nominal reference
    point before now, each mover measured (with noise, some missing) on its last samples."""
    v_ref = path.speed_mps
    hist_poses = path.pose_at_arclength(v_ref * T * np.arange(n_now)) if n_now else np.zeros((0, 3))
    v_mean = 0.5 * (robot_now.v_right_mps + robot_now.v_left_mps)
    first = [n_now - n + 1 for n in n_past]  # the sample at which each obstacle is first measured
    z = []  # positions computed per track at once
    for j, m in enumerate(movers):
        dt = T * (np.arange(first[j], n_now + 1) - n_now)
        x, y, _ = arc_step(np, m.position_m[0], m.position_m[1], m.heading_rad, m.speed_mps, m.turn_rate_rad_s, dt)
        zj = np.stack([x, y], axis=1) + rng.normal(0.0, st.measurement_std_m, (n_past[j], 2))
        zj[rng.random(n_past[j]) < st.p_missing] = np.nan
        z.append(zj)
    observations = []
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
    return tuple(observations)


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
                     tracker: SituationTracker | None = None, first_pass=None) -> Situation:
    """One random situation as the planner would see it (``info`` holds the tail);
    ``first_pass``: see :func:`episode_tail`."""
    tail = episode_tail(rng, config, layout_name, robot, settings, first_pass)
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
