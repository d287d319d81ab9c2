"""Seeded suites in buildings: ``corridor``, ``doorway`` and ``corner``.

Dimensions are a building's, not a toy's (docs/scenarios.md gives the reasons):

- ``corridor``: two walls 2.5 m apart (corridors of offices and hospitals are 1.8 to 3 m
  wide), 30 m long; the robot drives 10 m down the middle. Every wall runs on well beyond
  where anyone goes, as a building's do: there is no way round it within the time limit. The people walk the corridor both
  ways: half towards the robot, half its way ahead of it.
- ``doorway``: a wall across the robot's 10 m path with a 1.2 m gap at its middle (a wide
  door, or a double door half open: wide enough for the robot and one person, not two). The
  people cross the wall through the gap from both sides.
- ``corner``: an L of two corridors 2.5 m wide; the robot drives 4 m, turns left on an arc of
  1 m and drives 5 m up the other leg. The people come round the corner from that leg, and
  the walls hide them until late: a sensor does not see through walls.

The robot, the reference speed (0.4 m/s), the time limit (three times the nominal time) and
the people's discs (0.3 m) and preferred speeds (0.3 to 0.5 m/s) are the crowd suites'. The
people are walkers (``behaviour`` ``orca``, the default, or ``social_force``) that follow a
path through the building (a track of straight legs at their preferred speed: through the
door, round the corner) and avoid the walls and each other, not the robot
(``sees_robot = false``): a planner is measured on what it does itself. ``--movers`` (default
5) is how many. The seed fixes everything; the ``index``-th scenario does not depend on the
count.
"""
from __future__ import annotations

import math

import numpy as np

from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState

from .model import Scenario, Sensing, TrackSpec, Wall

__all__ = ["BUILDING_SUITES", "BUILDING_BEHAVIOURS", "building_scenario", "CORRIDOR_WIDTH_M", "DOOR_WIDTH_M"]

BUILDING_SUITES = ("corridor", "doorway", "corner")
BUILDING_BEHAVIOURS = ("orca", "social_force")
CORRIDOR_WIDTH_M = 2.5
DOOR_WIDTH_M = 1.2
PERSON_RADIUS_M = 0.3
PREFERRED_SPEED_MPS = (0.3, 0.5)
REFERENCE_SPEED_MPS = 0.4
TIME_LIMIT_FACTOR = 3.0
WALL_GAP_M = 0.1
"""Smallest gap between a person's disc and a wall on their path's legs."""
START_GAP_M = 0.3
"""Smallest gap between two people's discs, and between a person's and the robot's, at the
start."""


def _corridor(rng, k: int, n: int):
    half = CORRIDOR_WIDTH_M / 2
    walls = (Wall(((-10.0, half), (20.0, half))), Wall(((-10.0, -half), (20.0, -half))))
    lane = half - PERSON_RADIUS_M - WALL_GAP_M
    if k % 2 == 0:   # towards the robot
        path = [(rng.uniform(2.0, 12.0), rng.uniform(-lane, lane)), (-2.5, rng.uniform(-lane, lane))]
    else:            # its way, ahead of it
        path = [(rng.uniform(1.5, 8.0), rng.uniform(-lane, lane)), (12.5, rng.uniform(-lane, lane))]
    return walls, path


def _doorway(rng, k: int, n: int):
    gap = DOOR_WIDTH_M / 2
    walls = (Wall(((5.0, -15.0), (5.0, -gap))), Wall(((5.0, gap), (5.0, 15.0))))
    side = -1.0 if k % 2 == 0 else 1.0   # which side of the wall the person starts on
    lane = gap - PERSON_RADIUS_M        # through the door, clear of its posts
    start = (5.0 + side * rng.uniform(1.0, 4.5), rng.uniform(-4.0, 4.0))
    door = (5.0, rng.uniform(-lane, lane))
    goal = (5.0 - side * rng.uniform(2.0, 5.0), rng.uniform(-4.0, 4.0))
    return walls, [start, (door[0] + side * 0.6, door[1]), (door[0] - side * 0.6, door[1]), goal]


def _corner(rng, k: int, n: int):
    w = CORRIDOR_WIDTH_M
    outer = Wall(((-10.0, -w / 2), (5.0 + w / 2, -w / 2), (5.0 + w / 2, 18.0)))
    inner = Wall(((-10.0, w / 2), (5.0 - w / 2, w / 2), (5.0 - w / 2, 18.0)))
    lane = w / 2 - PERSON_RADIUS_M - WALL_GAP_M
    turn = (5.0 + rng.uniform(-lane, lane), rng.uniform(-lane, lane))
    if k % 2 == 0:   # comes round the corner towards the robot
        path = [(5.0 + rng.uniform(-lane, lane), rng.uniform(3.5, 9.0)), turn, (-1.0, rng.uniform(-lane, lane))]
    else:            # walks the robot's way, ahead of it
        path = [(rng.uniform(1.5, 4.0), rng.uniform(-lane, lane)), turn, (5.0 + rng.uniform(-lane, lane), 9.5)]
    return (outer, inner), path


_LAYOUTS = {"corridor": _corridor, "doorway": _doorway, "corner": _corner}


def _track(path, speed: float) -> tuple[tuple[float, float, float], ...]:
    """``(t, x, y)`` rows of straight legs through ``path`` at ``speed``, from t = 0."""
    rows, t = [(0.0, *path[0])], 0.0
    for a, b in zip(path[:-1], path[1:]):
        t += math.hypot(b[0] - a[0], b[1] - a[1]) / speed
        rows.append((round(t, 6), *b))
    return tuple((float(r[0]), float(r[1]), float(r[2])) for r in rows)


def _reference(kind: str) -> tuple[ReferencePath, RobotState]:
    if kind == "corner":
        segs = (Segment.line(4.0), Segment.arc(1.0, math.pi / 2), Segment.line(5.0))
    else:
        segs = (Segment.line(10.0),)
    return ReferencePath((0.0, 0.0), 0.0, segs, REFERENCE_SPEED_MPS), RobotState(0.0, 0.0, 0.0)


def building_scenario(kind: str, index: int, seed: int, movers: int = 5, behaviour: str = "orca") -> Scenario:
    """The ``index``-th scenario of building suite ``kind`` for ``seed``."""
    if kind not in BUILDING_SUITES:
        raise ValueError(f"unknown building suite {kind!r} (choose from {', '.join(BUILDING_SUITES)})")
    if behaviour not in BUILDING_BEHAVIOURS:
        raise ValueError(f"suite {kind}: unknown behaviour {behaviour!r} (choose from {', '.join(BUILDING_BEHAVIOURS)})")
    if int(movers) != movers or movers < 0:
        raise ValueError(f"movers must be a whole number, at least 0, got {movers}")
    rng = np.random.default_rng([seed, index, 200 + BUILDING_SUITES.index(kind), int(movers)])
    robot = RobotParams()
    ref, start = _reference(kind)
    walls, people, placed = (), [], [((0.0, 0.0), robot.radius_m)]
    for k in range(int(movers)):
        for _attempt in range(10000):
            walls, path = _LAYOUTS[kind](rng, k, int(movers))
            p0 = path[0]
            if all(math.hypot(p0[0] - q[0], p0[1] - q[1]) >= PERSON_RADIUS_M + r + START_GAP_M for q, r in placed):
                break
        else:
            raise ValueError(f"{kind}: cannot place {movers} people of {PERSON_RADIUS_M} m without overlap")
        placed.append((path[0], PERSON_RADIUS_M))
        speed = float(rng.uniform(*PREFERRED_SPEED_MPS))
        people.append(TrackSpec(PERSON_RADIUS_M, _track(path, speed), behaviour, False))
    if not walls:
        walls, _ = _LAYOUTS[kind](np.random.default_rng(0), 0, 0)
    return Scenario(
        name=f"{kind}-{behaviour}-{int(movers)}-{seed}-{index:04d}", duration_s=TIME_LIMIT_FACTOR * ref.duration_s,
        robot_start=start, reference=ref, robot=robot, moving=tuple(people),
        sensing=Sensing(0.02, int(seed * 100003 + index)), walls=tuple(walls),
        description=f"building suite {kind}, {movers} {behaviour} people, seed {seed}, index {index}",
    )
