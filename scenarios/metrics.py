"""Episode metrics and the contract's RUN.json / EVAL.json documents."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from casadi_gpc.geometry import distance_to_segments_m

from .simulator import RunLog

__all__ = ["EpisodeMetrics", "robot_approaching", "episode_metrics", "path_deviation_m", "same_instant_deviation_m", "passing_sides",
           "run_document", "eval_document", "time_stats", "longest_stop_s", "clopper_pearson_upper", "path_length_m",
           "DANGER_CLEARANCE_M", "intervention_count"]

STOP_SPEED_MPS = 0.05
APPROACH_SPEED_MPS = 0.05
"""A collision is the robot's own doing when its speed towards the obstacle was above this
(CONTRACT.md, ``collided_robot_approaching``)..."""
GHOST_TIME_S = 1.0
"""...and the obstacle had existed for at least this long (G-MPC's "ghost time": one who
appears on the robot at a recording's edge is not the robot's doing)."""
DANGER_CLEARANCE_M = 0.2
"""CrowdNav's discomfort distance: a sample whose clearance to some mover falls below this
is a sample in danger."""


def clopper_pearson_upper(failures: int, trials: int, confidence: float = 0.95) -> float:
    """One-sided Clopper-Pearson upper bound on a failure probability after ``failures`` in
    ``trials``: the largest p for which seeing so few failures still has probability at
    least ``1 - confidence`` (0 of 200 at 95 %: 1 - 0.05^(1/200) = 1.49 %)."""
    if trials < 1:
        return 1.0
    if not 0 <= failures <= trials:
        raise ValueError(f"failures must be within [0, {trials}], got {failures}")
    if failures == trials:
        return 1.0
    from scipy.stats import beta
    return float(beta.ppf(confidence, failures + 1, trials - failures))


def path_length_m(states, sample_time_s: float, times=None) -> float:
    """Length of the robot's path: each interval is an arc driven at the constant speed
    applied over it (the wheel speeds recorded with the state at its end), for
    ``sample_time_s``, or for the time between the records ``times`` when given (a collided
    run's last interval ends at the contact)."""
    st = np.asarray(states, dtype=float)
    if len(st) < 2:
        return 0.0
    dt = np.diff(np.asarray(times, dtype=float)) if times is not None else sample_time_s
    return float(np.sum(np.abs(0.5 * (st[1:, 3] + st[1:, 4])) * dt))


def intervention_count(events: dict) -> int:
    """Decisions changed by a safety check layer, as the controller counted them."""
    return int(events.get("interventions", events.get("safety_interventions", 0)))


def _point_to_polyline_m(points: np.ndarray, poly: np.ndarray) -> np.ndarray:
    """Distance from each point (n, 2) to the polyline ``poly`` (m, 2) (one point: to it)."""
    a, b = (poly, poly) if len(poly) == 1 else (poly[:-1], poly[1:])
    return distance_to_segments_m(points, a, b).min(axis=1)


def path_deviation_m(xy_a, xy_b) -> float:
    """How far apart two robot paths are, as curves: the largest distance from a sample of
    either path to the other path's polyline (the symmetric Hausdorff distance between the
    sampled points and the polylines). Timing does not enter: a robot that drives the same
    curve later or earlier has deviation 0."""
    a, b = np.asarray(xy_a, float)[:, :2], np.asarray(xy_b, float)[:, :2]
    return float(max(_point_to_polyline_m(a, b).max(), _point_to_polyline_m(b, a).max()))


def passing_sides(robot_xy, obstacle_xy) -> tuple[int, ...]:
    """The side the robot passed each obstacle on over a run: +1 on the right (the obstacle
    went by on the robot's left), -1 on the left, from the sign of the net turn of the
    bearing from the robot to the obstacle (unwrapped over the samples). Two runs passed an
    obstacle on the same side when their signs agree.

    ``robot_xy``: (n, 2) positions; ``obstacle_xy``: (n, k, 2) the k obstacles' positions
    at the same samples."""
    r = np.asarray(robot_xy, float)[:, None, :2]
    o = np.asarray(obstacle_xy, float).reshape(len(r), -1, 2)
    n = min(len(r), len(o))
    d = o[:n] - r[:n]
    turn = np.diff(np.unwrap(np.arctan2(d[..., 1], d[..., 0]), axis=0), axis=0).sum(axis=0)
    return tuple(1 if t >= 0 else -1 for t in np.atleast_1d(turn))


def same_instant_deviation_m(xy_a, xy_b, t_a=None, t_b=None) -> float:
    """The largest distance between two runs' robot positions at the same instants: with the
    records' times ``t_a``, ``t_b`` (RUN.json's ``trajectory.t``, ``RunLog.t``), at the instants both
    runs recorded (equal within 1e-9 s); without them, record by record over those both have. A
    collided run's last record is its contact, not a sample: paired by place, it was compared with
    the other run's next sample (found by an audit)."""
    a, b = np.asarray(xy_a, float)[:, :2], np.asarray(xy_b, float)[:, :2]
    if t_a is not None and t_b is not None:
        ta, tb = np.round(np.asarray(t_a, float) * 1e9), np.round(np.asarray(t_b, float) * 1e9)
        _, ia, ib = np.intersect1d(ta[:len(a)], tb[:len(b)], return_indices=True)
        a, b = a[ia], b[ib]
    n = min(len(a), len(b))
    return float(np.max(np.hypot(*(a[:n] - b[:n]).T)))


def time_stats(values, limit_s: float | None = None) -> dict:
    """Median, 95th and 99th percentiles, maximum and count of ``values`` (s); with
    ``limit_s`` (a sample time), also how many exceed it (``over_limit``)."""
    v = np.asarray(list(values), dtype=float)
    if v.size == 0:
        out = {"median": 0.0, "p95": 0.0, "p99": 0.0, "max": 0.0, "count": 0}
    else:
        out = {"median": float(np.median(v)), "p95": float(np.percentile(v, 95)),
               "p99": float(np.percentile(v, 99)), "max": float(v.max()), "count": int(v.size)}
    if limit_s is not None:
        out["over_limit"] = int(np.sum(v > limit_s))
    return out


def longest_stop_s(log: RunLog) -> float:
    """Longest time both wheels stayed under 0.05 m/s, excluding the start (the robot starts at
    rest) and, in a run that reached its goal, the end (standing at the goal is not a stop); a
    run that timed out or collided standing counts its last stop."""
    st = np.asarray(log.states)
    slow = np.all(np.abs(st[:, 3:5]) < STOP_SPEED_MPS, axis=1)
    slow[0] = False  # the robot starts at rest
    if log.outcome == "reached_goal":
        slow[-1] = False
    dt = np.diff(np.asarray(log.t, dtype=float))  # (a collided run's last interval ends at the contact)
    best = run = 0.0
    for s, d in zip(slow[1:], dt):
        run = run + d if s else 0.0
        best = max(best, run)
    return float(best)


def robot_approaching(collision: dict | None) -> bool:
    """Whether a collision (RUN.json's ``collision``; None: none) was the robot's own doing: it
    drove towards an obstacle that had been in the scene for :data:`GHOST_TIME_S` or more,
    faster than :data:`APPROACH_SPEED_MPS`. The age is compared with 1e-9 s to spare, as a track's
    times are (``within_window``): a contact 1 s after a track's first row at 0.4 s is 1.4 - 0.4 =
    0.9999999999999999 s in floating point, and was not counted (found by an audit)."""
    c = collision
    return bool(c) and c["robot_speed_towards_mps"] > APPROACH_SPEED_MPS and c["obstacle_age_s"] >= GHOST_TIME_S - 1e-9


@dataclass(frozen=True)
class EpisodeMetrics:
    scenario: str
    controller: str
    outcome: str
    min_clearance_m: float
    tracking_rmse_m: float
    time_to_goal_s: float | None
    steps: int
    fallbacks: int
    longest_stop_s: float
    compute_median_s: float
    path_length_m: float = 0.0
    danger_steps: int = 0
    """Samples at which the clearance to some mover was below :data:`DANGER_CLEARANCE_M`."""
    danger_clearance_sum_m: float = 0.0
    """Sum over those samples of their smallest clearance (for the mean over all)."""
    danger_samples: int | None = None
    """The samples the danger rate is a share of: the sample instants after the start, not a
    contact nor an end cut at ``duration_s`` (:meth:`RunLog.at_samples`); None: ``steps``."""
    interventions: int = 0
    collision: dict | None = None
    """What was hit and how (RUN.json's ``collision``), for a collided episode."""
    robot_radius_m: float | None = None
    """The radius of the episode's robot (a file's ``[robot] radius_m``: an evaluation may hold
    robots of several sizes)."""

    @property
    def robot_approaching(self) -> bool:
        """A collision of the robot's own doing (:func:`robot_approaching`)."""
        return robot_approaching(self.collision)

    @property
    def reached_goal(self) -> bool:
        return self.outcome == "reached_goal"

    @property
    def collided(self) -> bool:
        return self.outcome == "collided"


def episode_metrics(log: RunLog) -> EpisodeMetrics:
    st = np.asarray(log.states)
    ref = np.asarray(log.ref_poses)
    k = log.at_samples()  # the tracking error at the samples, not at a contact
    err = np.hypot(st[k, 0] - ref[k, 0], st[k, 1] - ref[k, 1])
    # CrowdNav's danger, as the contract counts it: the samples at which some mover is within 0.2 m
    # (interval i ends at record i + 1: those that end at a sample, not at a contact or duration_s)
    mover = np.asarray(log.mover_sample_clearance_m, dtype=float)[k[k > 0] - 1]
    danger = mover[mover < DANGER_CLEARANCE_M]
    return EpisodeMetrics(
        scenario=log.scenario.name,
        controller=log.controller,
        outcome=log.outcome,
        min_clearance_m=float(log.min_clearance_m) if math.isfinite(log.min_clearance_m) else 1e9,
        tracking_rmse_m=float(np.sqrt(np.mean(err ** 2))),
        time_to_goal_s=float(log.end_time_s) if log.outcome == "reached_goal" else None,
        steps=len(log.compute_time_s),
        fallbacks=int(log.fallbacks),
        longest_stop_s=longest_stop_s(log),
        compute_median_s=float(np.median(log.compute_time_s)) if log.compute_time_s else 0.0,
        path_length_m=path_length_m(log.states, log.sample_time_s, log.t),
        danger_steps=int(danger.size),
        danger_clearance_sum_m=float(danger.sum()),
        danger_samples=int(mover.size),
        interventions=intervention_count(log.events),
        collision=getattr(log, "collision", None),
        robot_radius_m=float(log.scenario.robot.radius_m),
    )


def _danger_samples(m: EpisodeMetrics) -> int:
    """The samples ``m``'s danger rate is a share of (until 2026-12-01 its steps, which count a
    collided run's contact and a run's end cut at ``duration_s``: not samples, and never in danger)."""
    return m.steps if m.danger_samples is None else m.danger_samples


def _nullable(values: np.ndarray) -> list:
    """A list for JSON, NaN (a mover not in the scene) as null."""
    return [None if v != v else float(v) for v in values.tolist()]


def run_document(log: RunLog, extra: dict | None = None) -> dict:
    """RUN.json as CONTRACT.md defines it (plus a few extra fields)."""
    m = episode_metrics(log)
    st = np.asarray(log.states)
    obs_xy = np.asarray(log.obstacle_xy)  # (samples, n, 2)
    obstacles = []
    sc = log.scenario
    kinds = [("moving", o) for o in sc.moving] + [("static", o) for o in sc.static]
    for j, (kind, ob) in enumerate(kinds):
        entry = {"kind": kind, "radius_m": ob.radius_m, "x": _nullable(obs_xy[:, j, 0]), "y": _nullable(obs_xy[:, j, 1])}
        if kind == "moving":
            entry["behaviour"] = ob.behaviour
            if hasattr(ob, "track"):  # x, y are null while it is not in the scene
                entry.update(track_start_s=ob.start_s, track_end_s=ob.end_s, sees_robot=ob.sees_robot)
            elif ob.behaviour != "constant":
                entry.update(goal=list(ob.goal_m), sees_robot=ob.sees_robot)
        obstacles.append(entry)
    doc = {
        "scenario": m.scenario,
        "controller": m.controller,
        "outcome": m.outcome,
        "collided": m.collided,
        "reached_goal": m.reached_goal,
        "min_clearance_m": m.min_clearance_m,
        "tracking_rmse_m": m.tracking_rmse_m,
        "time_to_goal_s": m.time_to_goal_s,
        "sample_time_s": log.sample_time_s,
        "steps": m.steps,
        "compute_time_s": time_stats(log.compute_time_s, log.sample_time_s),
        "fallbacks": m.fallbacks,
        "longest_stop_s": m.longest_stop_s,
        "path_length_m": m.path_length_m,
        "danger_rate": m.danger_steps / max(_danger_samples(m), 1),
        "min_clearance_in_danger_m": m.danger_clearance_sum_m / m.danger_steps if m.danger_steps else None,
        "interventions": m.interventions,
        "collision": m.collision,
        "clipped_commands": log.clipped_commands,
        "events": {k: int(v) for k, v in log.events.items()},
        "trajectory": {
            "t": [float(t) for t in log.t],
            "x": st[:, 0].tolist(), "y": st[:, 1].tolist(), "heading_rad": st[:, 2].tolist(),
            "v_right_mps": st[:, 3].tolist(), "v_left_mps": st[:, 4].tolist(),
        },
        "reference": {"x": np.asarray(log.ref_poses)[:, 0].tolist(), "y": np.asarray(log.ref_poses)[:, 1].tolist()},
        "obstacles": obstacles,
        "walls": [{"points": [list(pt) for pt in w.points]} for w in getattr(sc, "walls", ())],
        # the measurements' noise and its seed (simulate --seed overrides the file's): what reruns the episode
        "sensing": {"position_noise_std_m": sc.sensing.position_noise_std_m, "seed": sc.sensing.seed,
                    "range_m": sc.sensing.range_m},
    }
    doc.update(extra or {})
    return doc


def eval_document(controller: str, metrics: list[EpisodeMetrics], compute_times: list[float],
                  extra: dict | None = None) -> dict:
    """EVAL.json as CONTRACT.md defines it, with CrowdNav's measures: time to goal over the
    successes, the share of samples in danger (clearance to some mover below
    :data:`DANGER_CLEARANCE_M`) and the mean smallest clearance over them, path length, and
    one-sided 95 % Clopper-Pearson upper bounds on the collision and failure probabilities."""
    n = len(metrics)
    clear = np.array([m.min_clearance_m for m in metrics]) if n else np.zeros(1)
    rmse = np.array([m.tracking_rmse_m for m in metrics]) if n else np.zeros(1)
    ttg = [m.time_to_goal_s for m in metrics if m.reached_goal]
    samples = sum(_danger_samples(m) for m in metrics)
    danger = sum(m.danger_steps for m in metrics)
    collisions = sum(m.collided for m in metrics)
    failures = n - sum(m.reached_goal for m in metrics)
    doc = {
        "controller": controller,
        "episodes": n,
        "success_rate": sum(m.reached_goal for m in metrics) / max(n, 1),
        "collision_rate": sum(m.collided for m in metrics) / max(n, 1),
        "timeout_rate": sum(m.outcome == "timed_out" for m in metrics) / max(n, 1),
        "min_clearance_m": {"min": float(clear.min()), "median": float(np.median(clear))},
        "tracking_rmse_m": {"median": float(np.median(rmse))},
        "compute_time_s": time_stats(compute_times, (extra or {}).get("sample_time_s")),
        "fallbacks": int(sum(m.fallbacks for m in metrics)),
        "time_to_goal_s": {"mean": float(np.mean(ttg)), "median": float(np.median(ttg))} if ttg else None,
        "danger_rate": danger / max(samples, 1),
        "min_clearance_in_danger_m": sum(m.danger_clearance_sum_m for m in metrics) / danger if danger else None,
        "path_length_m": {"median": float(np.median([m.path_length_m for m in metrics])) if n else 0.0},
        "collision_rate_upper_95": clopper_pearson_upper(collisions, n),
        "failure_rate_upper_95": clopper_pearson_upper(failures, n),
        "interventions": int(sum(m.interventions for m in metrics)),
        "collided_robot_approaching": int(sum(m.robot_approaching for m in metrics)),
        "episodes_detail": [asdict(m) for m in metrics],
    }
    doc.update(extra or {})
    return doc
