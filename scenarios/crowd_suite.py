"""Seeded crowd scenarios in CrowdNav's geometry: ``circle-crossing`` and ``square-crossing``.

The robot drives from (0, -4) to (0, 4): a straight reference at 0.4 m/s (20 s), with a time
limit of three times that, 60 s (CrowdNav's ratio: 25 s for 8 m at 1 m/s). Each of the
``movers`` (default 5) has radius 0.3 m and a preferred speed drawn from U(0.3, 0.5) m/s:

- ``circle-crossing``: a mover starts on the circle of radius 4 m around the origin at an
  angle drawn uniformly and walks to the opposite point of the circle;
- ``square-crossing``: a mover starts at a uniform point of one side (drawn uniformly among
  the four) of the 10 m square centred at the origin and walks to a uniform point of the
  opposite side.

A draw is rejected and redrawn when the mover's disc would come within
:data:`START_GAP_M` of another mover's (at the starts, and at the goals, where walkers
stand) or within :data:`ROBOT_GAP_M` of the robot's at its start. The ``behaviour``
(``orca``, default, or ``social_force``) makes the movers walkers that avoid each other but
not the robot (``sees_robot = false``); ``constant`` gives each mover the constant course
from its start towards its goal at its preferred speed, which it keeps beyond the goal (a
constant mover has no goal to stop at). The seed fixes everything: the ``index``-th
scenario of a suite does not depend on the count.
"""
from __future__ import annotations

import math

import numpy as np

from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState

from .model import MovingObstacleSpec, Scenario, Sensing, WalkerSpec

__all__ = ["CROWD_SUITES", "CROWD_BEHAVIOURS", "crowd_scenario", "START_GAP_M", "ROBOT_GAP_M"]

CROWD_SUITES = ("circle-crossing", "square-crossing")
CROWD_BEHAVIOURS = ("constant", "orca", "social_force")
CIRCLE_RADIUS_M = 4.0
SQUARE_SIDE_M = 10.0
MOVER_RADIUS_M = 0.3
PREFERRED_SPEED_MPS = (0.3, 0.5)
ROBOT_START, ROBOT_GOAL = (0.0, -4.0), (0.0, 4.0)
REFERENCE_SPEED_MPS = 0.4
TIME_LIMIT_FACTOR = 3.0
START_GAP_M = 0.1
"""Smallest gap between two movers' discs at their starts and at their goals."""
ROBOT_GAP_M = 0.3
"""Smallest gap between a mover's disc and the robot's at the start."""


def _circle(rng) -> tuple[tuple[float, float], tuple[float, float]]:
    a = rng.uniform(0.0, 2.0 * math.pi)
    start = (CIRCLE_RADIUS_M * math.cos(a), CIRCLE_RADIUS_M * math.sin(a))
    return start, (-start[0], -start[1])


def _square(rng) -> tuple[tuple[float, float], tuple[float, float]]:
    half = 0.5 * SQUARE_SIDE_M
    side = int(rng.integers(0, 4))  # 0: bottom, 1: right, 2: top, 3: left
    u, v = rng.uniform(-half, half), rng.uniform(-half, half)
    ends = {0: ((u, -half), (v, half)), 1: ((half, u), (-half, v)), 2: ((u, half), (v, -half)),
            3: ((-half, u), (half, v))}
    return ends[side]


def _clear(p, others, radius: float, gap: float) -> bool:
    return all(math.hypot(p[0] - q[0], p[1] - q[1]) >= radius + r + gap for q, r in others)


def crowd_scenario(kind: str, index: int, seed: int, movers: int = 5, behaviour: str = "orca") -> Scenario:
    """The ``index``-th scenario of crowd suite ``kind`` for ``seed``."""
    if kind not in CROWD_SUITES:
        raise ValueError(f"unknown crowd suite {kind!r} (choose from {', '.join(CROWD_SUITES)})")
    if behaviour not in CROWD_BEHAVIOURS:
        raise ValueError(f"unknown behaviour {behaviour!r} (choose from {', '.join(CROWD_BEHAVIOURS)})")
    if int(movers) != movers or movers < 0:
        raise ValueError(f"movers must be a whole number, at least 0, got {movers}")
    rng = np.random.default_rng([seed, index, 100 + CROWD_SUITES.index(kind), int(movers)])
    robot = RobotParams()
    draw = _circle if kind == "circle-crossing" else _square
    starts, goals, specs = [], [], []
    for _ in range(int(movers)):
        for _attempt in range(10000):
            start, goal = draw(rng)
            if (_clear(start, starts, MOVER_RADIUS_M, START_GAP_M) and _clear(goal, goals, MOVER_RADIUS_M, START_GAP_M)
                    and _clear(start, [(ROBOT_START, robot.radius_m)], MOVER_RADIUS_M, ROBOT_GAP_M)):
                break
        else:
            raise ValueError(f"{kind}: cannot place {movers} movers of {MOVER_RADIUS_M} m without overlap")
        speed = float(rng.uniform(*PREFERRED_SPEED_MPS))
        starts.append((start, MOVER_RADIUS_M))
        goals.append((goal, MOVER_RADIUS_M))
        if behaviour == "constant":
            heading = math.atan2(goal[1] - start[1], goal[0] - start[0])
            specs.append(MovingObstacleSpec(start, heading, speed, MOVER_RADIUS_M))
        else:
            specs.append(WalkerSpec(start, MOVER_RADIUS_M, behaviour, goal, speed, False))
    length = ROBOT_GOAL[1] - ROBOT_START[1]
    ref = ReferencePath(ROBOT_START, math.pi / 2, (Segment.line(length),), REFERENCE_SPEED_MPS)
    return Scenario(
        name=f"{kind}-{behaviour}-{int(movers)}-{seed}-{index:04d}", duration_s=TIME_LIMIT_FACTOR * ref.duration_s,
        robot_start=RobotState(*ROBOT_START, math.pi / 2), reference=ref, robot=robot, moving=tuple(specs),
        sensing=Sensing(0.02, int(seed * 100003 + index)),
        description=f"crowd suite {kind}, {movers} {behaviour} movers, seed {seed}, index {index}",
    )
