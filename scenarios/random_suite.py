"""Seeded random scenarios: ``random`` (one moving obstacle on a conflict course),
``random-multi`` (up to three moving and three static obstacles) and ``encounters`` (the
family of the paper's Fig. 7: a straight path, one obstacle head-on or crossing).

Distributions (docs/scenarios.md): the reference starts at the origin heading along x, a
line of 4-8 m, then with probability 1/2 an arc (radius 3-8 m, +-20..90 deg) and a final
line of 4-8 m; speed 0.25-0.45 m/s. A moving obstacle (radius 0.2-0.4 m, speed 0.1-0.5 m/s)
is placed so that it would pass within 0.3 m of the reference point at a conflict time in
the middle half of the run, coming from a direction 30-330 deg off the path's tangent.
Static obstacles sit 0.4-1.5 m beside the path.

``encounters``: a straight reference of 12-20 m at 0.3-0.5 m/s; the robot starts on the path
(60 %) or up to 1.2 m beside it; one obstacle (radius 0.2-0.4 m, speed 0.2-0.4 m/s) meets the
reference point within 0.4 m at a time in the middle 30-70 % of the run, either head-on
(1/3: 170-190 deg off the path's direction) or crossing (2/3: 60-120 deg from either side).
The paper's three situations are members of this family; the suite never contains them.
"""
from __future__ import annotations

import math

import numpy as np

from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState
from casadi_gpc.types import StaticObstacle

from .model import MovingObstacleSpec, Scenario, Sensing

__all__ = ["SUITES", "random_suite", "random_scenario"]

SUITES = ("random", "random-multi", "encounters")


def _reference(rng: np.random.Generator, robot: RobotParams) -> ReferencePath:
    segs = [Segment.line(rng.uniform(4.0, 8.0))]
    if rng.random() < 0.5:
        radius = rng.uniform(3.0, 8.0)
        segs.append(Segment.arc(radius, math.radians(rng.choice([-1, 1]) * rng.uniform(20, 90))))
    segs.append(Segment.line(rng.uniform(4.0, 8.0)))
    return ReferencePath((0.0, 0.0), 0.0, tuple(segs), float(rng.uniform(0.25, 0.45)))


def _conflict_obstacle(rng, ref: ReferencePath, robot: RobotParams, t_lo: float, t_hi: float,
                       rel_deg=None, speed=(0.1, 0.5), lateral_m: float = 0.3) -> MovingObstacleSpec:
    for _ in range(1000):
        t_c = rng.uniform(t_lo, t_hi)
        cx, cy, ch = ref.pose_at_time(t_c)
        rel = math.radians(rng.uniform(30.0, 330.0) if rel_deg is None else rel_deg(rng))
        heading = ch + rel
        speed_mps = rng.uniform(*speed)
        radius = rng.uniform(0.2, 0.4)
        lateral = rng.uniform(-lateral_m, lateral_m)
        px = cx - speed_mps * t_c * math.cos(heading) - lateral * math.sin(ch)
        py = cy - speed_mps * t_c * math.sin(heading) + lateral * math.cos(ch)
        if math.hypot(px, py) > robot.radius_m + radius + 1.0:
            return MovingObstacleSpec((float(px), float(py)), float(heading), float(speed_mps), float(radius))
    raise RuntimeError("could not place an obstacle")  # practically unreachable


def random_scenario(kind: str, index: int, seed: int) -> Scenario:
    """The ``index``-th scenario of suite ``kind`` for ``seed`` (independent of the count)."""
    if kind not in SUITES:
        raise ValueError(f"unknown suite {kind!r} (choose from {', '.join(SUITES)})")
    rng = np.random.default_rng([seed, index, SUITES.index(kind)])
    robot = RobotParams()
    if kind == "encounters":
        return _encounter(rng, robot, index, seed)
    ref = _reference(rng, robot)
    t_end = ref.duration_s
    n_moving = 1 if kind == "random" else int(rng.integers(1, 4))
    moving = tuple(_conflict_obstacle(rng, ref, robot, 0.25 * t_end, 0.75 * t_end) for _ in range(n_moving))
    static = []
    if kind == "random-multi":
        for _ in range(int(rng.integers(0, 4))):
            s = rng.uniform(3.0, ref.length_m - 1.0)
            x, y, h = ref.pose_at_arclength(s)
            off = rng.choice([-1, 1]) * rng.uniform(0.4, 1.5)
            static.append(StaticObstacle((float(x - off * math.sin(h)), float(y + off * math.cos(h))),
                                         float(rng.uniform(0.15, 0.35))))
    return Scenario(
        name=f"{kind}-{seed}-{index:04d}", duration_s=float(t_end + 30.0), robot_start=RobotState(0.0, 0.0, 0.0),
        reference=ref, robot=robot, moving=moving, static=tuple(static),
        sensing=Sensing(0.02, int(seed * 100003 + index)),
        description=f"random suite {kind}, seed {seed}, index {index}",
    )


def _head_on_or_crossing(rng) -> float:
    if rng.random() < 1.0 / 3.0:
        return 180.0 + rng.uniform(-10.0, 10.0)
    return float(rng.choice([-1, 1])) * rng.uniform(60.0, 120.0)


def _encounter(rng, robot: RobotParams, index: int, seed: int) -> Scenario:
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(rng.uniform(12.0, 20.0)),), float(rng.uniform(0.3, 0.5)))
    t_end = ref.duration_s
    off = 0.0 if rng.random() < 0.6 else rng.uniform(-1.2, 1.2)
    obstacle = _conflict_obstacle(rng, ref, robot, 0.3 * t_end, 0.7 * t_end, _head_on_or_crossing, (0.2, 0.4), 0.4)
    return Scenario(
        name=f"encounters-{seed}-{index:04d}", duration_s=float(t_end + 30.0), robot_start=RobotState(0.0, off, 0.0),
        reference=ref, robot=robot, moving=(obstacle,), static=(),
        sensing=Sensing(0.02, int(seed * 100003 + index)),
        description=f"random suite encounters, seed {seed}, index {index}",
    )


def random_suite(kind: str, count: int, seed: int) -> list[Scenario]:
    return [random_scenario(kind, i, seed) for i in range(count)]
