"""Seeded random scenarios: ``random`` (one moving obstacle on a conflict course) and
``random-multi`` (up to three moving and three static obstacles).

Distributions (docs/scenarios.md): the reference starts at the origin heading along x, a
line of 4-8 m, then with probability 1/2 an arc (radius 3-8 m, +-20..90 deg) and a final
line of 4-8 m; speed 0.25-0.45 m/s. A moving obstacle (radius 0.2-0.4 m, speed 0.1-0.5 m/s)
is placed so that it would pass within 0.3 m of the reference point at a conflict time in
the middle half of the run, coming from a direction 30-330 deg off the path's tangent.
Static obstacles sit 0.4-1.5 m beside the path.
"""
from __future__ import annotations

import math

import numpy as np

from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState
from casadi_gpc.types import StaticObstacle

from .model import MovingObstacleSpec, Scenario, Sensing

__all__ = ["SUITES", "random_suite", "random_scenario"]

SUITES = ("random", "random-multi")


def _reference(rng: np.random.Generator, robot: RobotParams) -> ReferencePath:
    segs = [Segment.line(rng.uniform(4.0, 8.0))]
    if rng.random() < 0.5:
        radius = rng.uniform(3.0, 8.0)
        segs.append(Segment.arc(radius, math.radians(rng.choice([-1, 1]) * rng.uniform(20, 90))))
    segs.append(Segment.line(rng.uniform(4.0, 8.0)))
    return ReferencePath((0.0, 0.0), 0.0, tuple(segs), float(rng.uniform(0.25, 0.45)))


def _conflict_obstacle(rng, ref: ReferencePath, robot: RobotParams, t_lo: float, t_hi: float) -> MovingObstacleSpec:
    for _ in range(1000):
        t_c = rng.uniform(t_lo, t_hi)
        cx, cy, ch = ref.pose_at_time(t_c)
        rel = math.radians(rng.uniform(30.0, 330.0))
        heading = ch + rel
        speed = rng.uniform(0.1, 0.5)
        radius = rng.uniform(0.2, 0.4)
        lateral = rng.uniform(-0.3, 0.3)
        px = cx - speed * t_c * math.cos(heading) - lateral * math.sin(ch)
        py = cy - speed * t_c * math.sin(heading) + lateral * math.cos(ch)
        if math.hypot(px, py) > robot.radius_m + radius + 1.0:
            return MovingObstacleSpec((float(px), float(py)), float(heading), float(speed), float(radius))
    raise RuntimeError("could not place an obstacle")  # practically unreachable


def random_scenario(kind: str, index: int, seed: int) -> Scenario:
    """The ``index``-th scenario of suite ``kind`` for ``seed`` (independent of the count)."""
    if kind not in SUITES:
        raise ValueError(f"unknown suite {kind!r} (choose from {', '.join(SUITES)})")
    rng = np.random.default_rng([seed, index, SUITES.index(kind)])
    robot = RobotParams()
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


def random_suite(kind: str, count: int, seed: int) -> list[Scenario]:
    return [random_scenario(kind, i, seed) for i in range(count)]
