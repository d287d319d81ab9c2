"""Initial guesses for the multi-start solve.

The cost is not convex near obstacles: a head-on encounter has a pass-left and a
pass-right minimum, and an obstacle (or a gap too narrow to pass) in front of a stopped
robot has a "wait" minimum, which the ``brake`` guess (slow down at the acceleration limit
and stand) starts in: in a crowd, a moving robot's guesses all lead into the crowd. Solving from several guesses and keeping the cheapest answer
finds the minimum a single warm start would miss. The order of the guesses is the order
ties are broken in (``TIE_ORDER``): swerve right first, so an exact tie passes on the right.
"""
from __future__ import annotations

import math

import numpy as np

from numba import njit

from ..geometry import distance_to_segments_m, segments_cross
from ..robot import robot_step_compiled, robot_step_float

__all__ = ["TIE_ORDER", "check_guess_names", "SIDEWAYS", "NARROWER", "wheels_to_increments", "swerve_guesses",
           "detour_guesses", "brake_guess", "initial_guesses", "meets_walls", "meets_walls_reference",
           "plan_meets_walls", "fitted_guesses"]

TIE_ORDER = ("swerve_right", "swerve_left", "straight", "detour_right", "detour_left", "brake")
DETOUR_OFFSETS_M = (-1.5, 1.5)  # lateral shifts of the reference that the detour guesses follow
SIDEWAYS = frozenset({"swerve_right", "swerve_left", "detour_right", "detour_left"})
"""The guesses that leave the reference sideways, by a turn rate or a lateral offset."""

NARROWER = (0.5, 0.25)
"""A sideways guess that meets a wall (:func:`meets_walls`) is made again with its turn rate
or offset scaled by each of these in turn, and the first that keeps off the walls is solved:
in a 2.5 m corridor the full swerve (0.5 rad/s for half the horizon) and the 1.5 m detours
leave it, and without a narrower one the robot's only cold guesses there are straight on and
braking (docs/buildings.md, "Guesses that fit the corridor")."""


def check_guess_names(names) -> None:
    """Refuse (ValueError) a guess name not in :data:`TIE_ORDER`, and no guess at all: a planner
    with none never solves (every decision its fallback: the robot stood for the whole run)."""
    unknown = sorted(set(names) - set(TIE_ORDER))
    if unknown:
        raise ValueError(f"unknown initial guesses {unknown} (choose from {', '.join(TIE_ORDER)})")
    if not names:
        raise ValueError(f"guesses: give at least one initial guess (of {', '.join(TIE_ORDER)}): with none the "
                         f"planner never solves")


def _follow(v: float, target: float, dv_max: float, v_max: float) -> float:
    """One wheel's increment towards ``target`` within the rate and speed limits."""
    step = min(max(target - v, -dv_max), dv_max)
    return min(max(v + step, -v_max), v_max) - v


def wheels_to_increments(v0, wheels, dv_max: float, v_max: float) -> np.ndarray:
    """Increments that follow target wheel speeds as closely as the limits allow (plain
    floats: a full multi-start makes a few hundred of these steps)."""
    vr, vl = float(v0[0]), float(v0[1])
    u = []
    for tr, tl in np.asarray(wheels, dtype=float).tolist():
        a, b = _follow(vr, tr, dv_max, v_max), _follow(vl, tl, dv_max, v_max)
        u += (a, b)
        vr, vl = vr + a, vl + b
    return np.array(u)


def swerve_guesses(cfg, robot, x0, ref_speed_mps: float, scale: float = 1.0) -> dict[str, np.ndarray]:
    """Turn one way for half the horizon and back the other way (and straight on); ``scale``
    multiplies the turn rate."""
    H, W = cfg.horizon, robot.wheel_base_m
    dv_max, v_max = robot.max_step_change_mps(cfg.sample_time_s), robot.max_wheel_speed_mps
    v = float(np.clip(ref_speed_mps, 0.0, v_max))
    half = max(1, H // 2)
    out = {}
    for name, sign in (("swerve_right", -1.0), ("swerve_left", 1.0), ("straight", 0.0)):
        w = np.where(np.arange(H) < half, sign, -sign) * cfg.swerve_turn_rate_rad_s * scale
        wheels = np.stack([v + 0.5 * w * W, v - 0.5 * w * W], axis=1)
        out[name] = wheels_to_increments(x0[3:5], wheels, dv_max, v_max)
    return out


def detour_guesses(cfg, robot, x0, ref_poses, ref_speed_mps: float, gain: float = 1.5,
                   scale: float = 1.0) -> dict[str, np.ndarray]:
    """Steer towards the reference shifted sideways (a way around what blocks the path):
    a simple pursuit of the shifted points, rolled out with the robot model; ``scale``
    multiplies the shift."""
    H, W, T = cfg.horizon, robot.wheel_base_m, cfg.sample_time_s
    dv_max, v_max = robot.max_step_change_mps(T), robot.max_wheel_speed_mps
    ref = np.asarray(ref_poses, dtype=float).tolist()
    out = {}
    for name, offset in zip(("detour_right", "detour_left"), DETOUR_OFFSETS_M):
        offset *= scale
        x, y, th = float(x0[0]), float(x0[1]), float(x0[2])
        vr, vl = float(x0[3]), float(x0[4])
        u = []
        for rx, ry, rh in ref[:H]:
            dx, dy = rx - offset * math.sin(rh) - x, ry + offset * math.cos(rh) - y  # the shifted point
            err = math.atan2(dy, dx) - th
            err = math.atan2(math.sin(err), math.cos(err))
            speed = min(max(ref_speed_mps, 0.1), math.hypot(dx, dy) / T) * max(math.cos(err), 0.0)
            w = gain * err
            a = _follow(vr, speed + 0.5 * w * W, dv_max, v_max)
            b = _follow(vl, speed - 0.5 * w * W, dv_max, v_max)
            u += (a, b)
            vr, vl = vr + a, vl + b
            x, y, th = robot_step_float(x, y, th, vr, vl, T, W)
        out[name] = np.array(u)
    return out


def brake_guess(cfg, robot, x0) -> np.ndarray:
    """Both wheels to a stand at the acceleration limit, then standing."""
    H, dv_max, v_max = cfg.horizon, robot.max_step_change_mps(cfg.sample_time_s), robot.max_wheel_speed_mps
    return wheels_to_increments(x0[3:5], np.zeros((H, 2)), dv_max, v_max)


def initial_guesses(problem, x0, ref_speed_mps: float, ref_poses=None, names=None,
                    scale: float = 1.0) -> dict[str, np.ndarray]:
    """The configuration's fixed guesses (``PlannerConfig.guesses``; ``names``: only those
    of them) in tie-break order (detours only when the reference is known); ``scale``
    multiplies the sideways guesses' turn rate and offset (:data:`NARROWER`)."""
    cfg, wanted = problem.config, set(problem.config.guesses)
    if names is not None:
        wanted &= set(names)
    swerving = wanted & {"swerve_right", "swerve_left", "straight"}
    guesses = swerve_guesses(cfg, problem.robot, x0, ref_speed_mps, scale) if swerving else {}
    if ref_poses is not None and wanted & {"detour_right", "detour_left"}:
        guesses.update(detour_guesses(cfg, problem.robot, x0, ref_poses, ref_speed_mps, scale=scale))
    if "brake" in wanted:
        guesses["brake"] = brake_guess(cfg, problem.robot, x0)
    return {k: guesses[k] for k in TIE_ORDER if k in guesses and k in wanted}


def meets_walls(config, robot, x0, u0, segments) -> bool:
    """Whether the path the increments ``u0`` roll out to from ``x0`` crosses one of the wall
    ``segments`` (``(ax, ay, bx, by)`` each; straight chords between the samples) or brings the
    robot's disc onto one at a sample (nearer than its radius, and nearer than it is now). A
    wall, unlike a disc, cannot be passed on either side: a guess through it starts the
    solver deep inside a penalty it cannot leave."""
    if not len(segments):
        return False
    x, y, th, vr, vl = (float(v) for v in x0)
    return bool(_meets_walls(x, y, th, vr, vl, np.ascontiguousarray(u0, dtype=float).reshape(-1), int(config.horizon),
                             float(config.sample_time_s), float(robot.wheel_base_m),
                             np.ascontiguousarray(segments, dtype=float).reshape(-1, 4), float(robot.radius_m)))


def meets_walls_reference(config, robot, x0, u0, segments) -> bool:
    """:func:`meets_walls` with numpy's geometry (:func:`~casadi_gpc.geometry.segments_cross`,
    :func:`~casadi_gpc.geometry.distance_to_segments_m`) and the robot model's float form: what
    the compiled form is tested against, answer for answer."""
    if not len(segments):
        return False
    x, y, th, vr, vl = (float(v) for v in x0)
    pts = [(x, y)]
    for k in range(config.horizon):
        vr, vl = vr + float(u0[2 * k]), vl + float(u0[2 * k + 1])
        x, y, th = robot_step_float(x, y, th, vr, vl, config.sample_time_s, robot.wheel_base_m)
        pts.append((x, y))
    seg = np.asarray(segments, dtype=float).reshape(-1, 4)
    a, b = seg[:, :2], seg[:, 2:]
    if segments_cross(pts[:-1], pts[1:], a, b).any():
        return True
    d = distance_to_segments_m(np.asarray(pts), a, b)          # (H + 1, m)
    return bool((d[1:] < np.minimum(robot.radius_m, d[0]) - 1e-9).any())


@njit("boolean(float64, float64, float64, float64, float64, float64[::1], int64, float64, float64, float64[:, ::1], "
      "float64)", cache=True)
def _meets_walls(x, y, th, vr, vl, u, H, T, W, seg, radius):  # pragma: no cover - compiled
    """:func:`meets_walls_reference` in one compiled call: the same roll-out (the robot model's
    float form compiled), the same orientation tests and distances, operation for operation."""
    px, py = np.empty(H + 1), np.empty(H + 1)
    px[0], py[0] = x, y
    for k in range(H):
        vr, vl = vr + u[2 * k], vl + u[2 * k + 1]
        x, y, th = robot_step_compiled(x, y, th, vr, vl, T, W)
        px[k + 1], py[k + 1] = x, y
    m = seg.shape[0]
    for i in range(H):  # the chords against the segments (geometry.segments_cross)
        p0, p1, q0, q1 = px[i], py[i], px[i + 1], py[i + 1]
        for j in range(m):
            a0, a1, b0, b1 = seg[j, 0], seg[j, 1], seg[j, 2], seg[j, 3]
            abp = (b0 - a0) * (p1 - a1) - (b1 - a1) * (p0 - a0)
            abq = (b0 - a0) * (q1 - a1) - (b1 - a1) * (q0 - a0)
            pqa = (q0 - p0) * (a1 - p1) - (q1 - p1) * (a0 - p0)
            pqb = (q0 - p0) * (b1 - p1) - (q1 - p1) * (b0 - p0)
            if abp * abq <= 0 and pqa * pqb <= 0:
                return True
    for j in range(m):  # the samples' distances (geometry.distance_to_segments_m)
        a0, a1 = seg[j, 0], seg[j, 1]
        ab0, ab1 = seg[j, 2] - a0, seg[j, 3] - a1
        den = ab0 * ab0 + ab1 * ab1
        if not den >= 1e-18 and den == den:  # np.maximum(den, 1e-18), NaN kept
            den = 1e-18
        limit = 0.0
        for i in range(H + 1):
            t = ((px[i] - a0) * ab0 + (py[i] - a1) * ab1) / den
            if t < 0.0:  # np.clip(t, 0, 1), NaN kept
                t = 0.0
            elif t > 1.0:
                t = 1.0
            d0, d1 = px[i] - (a0 + t * ab0), py[i] - (a1 + t * ab1)
            d = math.sqrt(d0 * d0 + d1 * d1)
            if i == 0:
                limit = (radius if radius < d or radius != radius else d) - 1e-9  # np.minimum(radius, d), NaN kept
            elif d < limit:
                return True
    return False


def plan_meets_walls(config, robot, x0, plan, segments) -> bool:
    """Whether a solved ``plan`` (the last tick's, its increments ``plan.u``), shifted by a
    step and rolled out from the state ``x0``, meets the wall ``segments`` (:func:`meets_walls`);
    False without a plan or a segment. A plan the solver took through a wall (started there,
    it stays in the wall's penalty) is no minimum for the planner to keep: beside a wall, with
    no one near, it used to be kept for 10 to 15 s (docs/buildings.md, "A robot that starts
    against a wall")."""
    if plan is None or not len(segments):
        return False
    u = np.concatenate([np.asarray(plan.u, dtype=float)[2:], np.zeros(2)])
    return meets_walls(config, robot, x0, u, segments)


def fitted_guesses(problem, x0, ref_speed_mps: float, ref_poses, guesses: dict, segments) -> tuple[dict, int]:
    """``guesses`` (name -> increments, as :func:`initial_guesses` gives them) fitted to the
    wall ``segments``: one that meets a wall (:func:`meets_walls`) is made again narrower if it
    goes sideways (:data:`NARROWER`, the first scale that keeps off the walls), else left
    out. The kept guesses in their order, and how many were narrowed."""
    cfg, robot = problem.config, problem.robot
    if not len(segments):
        return dict(guesses), 0
    out, narrowed = {}, 0
    for name, u0 in guesses.items():
        if not meets_walls(cfg, robot, x0, u0, segments):
            out[name] = u0
            continue
        for scale in NARROWER if name in SIDEWAYS else ():
            u = initial_guesses(problem, x0, ref_speed_mps, ref_poses, (name,), scale)[name]
            if not meets_walls(cfg, robot, x0, u, segments):
                out[name], narrowed = u, narrowed + 1
                break
    return out, narrowed
