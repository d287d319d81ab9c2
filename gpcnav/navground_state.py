"""What a navground behaviour knows, as gpcnav's controllers are told it: navground's target
becomes a :class:`~casadi_gpc.reference.ReferencePath`, its neighbours measured obstacles
with ids that last, its discs and line segments static obstacles.

Numpy only: navground's objects are read through their attributes (``position``,
``radius``, ``velocity``; a target's ``position`` and ``path``; a segment's ``p1``, ``p2``),
so this module imports neither navground nor the planner (used by
:mod:`gpcnav.navground_plugin`; tested with stand-ins).
"""
from __future__ import annotations

import math

import numpy as np

from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.types import ObstacleMeasurement, StaticObstacle

__all__ = ["NeighbourTracks", "reference_to_target", "target_key", "static_obstacles", "walls", "PATH_STEP_M",
           "DIRECTION_LINE_M"]

PATH_STEP_M = 0.1
"""A navground path target is followed as a reference of pieces this long, each turning as
the path turns over it (a polyline's corner becomes an arc of this length)."""

DIRECTION_LINE_M = 10_000.0
"""A direction target (navground's ``Direction`` task, which its ``Corridor`` scenario gives every
agent: a direction, no point) is followed as a straight line this long from where the robot is
when it is set, in that direction (at 0.4 m/s, 7 hours of navground time)."""


def _direction(target) -> np.ndarray | None:
    """The unit vector of a target that has a direction and no point, else None."""
    if getattr(target, "position", None) is not None:
        return None
    d = getattr(target, "direction", None)
    if d is None:
        return None
    d = np.asarray(d, dtype=float)
    norm = float(np.hypot(*d))
    return d / norm if norm > 0.0 and math.isfinite(norm) else None


def target_key(target) -> tuple | None:
    """What identifies a target for the reference made from it (a new key: a new
    reference): the end point, and for a path its length. None: no position to reach."""
    path = getattr(target, "path", None)
    if path is not None:
        end, _, _ = path.curve(path.length)
        return ("path", round(float(path.length), 6), *np.round(np.asarray(end, dtype=float), 6))
    position = getattr(target, "position", None)
    if position is None:
        direction = _direction(target)
        return None if direction is None else ("direction", *np.round(direction, 6))
    return ("point", *np.round(np.asarray(position, dtype=float), 6))


def reference_to_target(target, xy_m, speed_mps: float) -> ReferencePath | None:
    """The reference the controller follows to navground's ``target``, from the robot at
    ``xy_m`` at navground's optimal speed: along the target's path from the robot's
    projection on it, else the straight line to its point, or for a target with a direction and
    no point the straight line of :data:`DIRECTION_LINE_M` that way. None: nothing to drive to
    (no point or direction, or already on the point)."""
    if not speed_mps > 0.0:
        return None
    xy = np.asarray(xy_m, dtype=float)
    path = getattr(target, "path", None)
    if path is not None:
        length = float(path.length)
        s0 = float(path.project(xy.astype(np.float32), 0.0, length))
        if length - s0 < 1e-3:
            return None
        n = max(1, int(math.ceil((length - s0) / PATH_STEP_M)))
        s = np.linspace(s0, length, n + 1)
        poses = [path.curve(float(si)) for si in s]
        headings = np.unwrap([float(h) for _, h, _ in poses])
        ds = (length - s0) / n
        segments = tuple(Segment(ds, float(headings[i + 1] - headings[i]) / ds) for i in range(n))
        start = np.asarray(poses[0][0], dtype=float)
        return ReferencePath((float(start[0]), float(start[1])), float(headings[0]), segments, float(speed_mps))
    position = getattr(target, "position", None)
    if position is None:
        d = _direction(target)
        if d is None:
            return None
        return ReferencePath((float(xy[0]), float(xy[1])), math.atan2(d[1], d[0]), (Segment.line(DIRECTION_LINE_M),),
                             float(speed_mps))
    delta = np.asarray(position, dtype=float) - xy
    distance = float(math.hypot(*delta))
    if distance < 1e-3:
        return None
    return ReferencePath((float(xy[0]), float(xy[1])), math.atan2(delta[1], delta[0]), (Segment.line(distance),),
                         float(speed_mps))


def static_obstacles(discs) -> tuple[StaticObstacle, ...]:
    """navground's static discs as gpcnav's static obstacles."""
    return tuple(StaticObstacle((float(d.position[0]), float(d.position[1])), float(d.radius)) for d in discs)


def walls(lines) -> tuple[tuple[tuple[float, float], ...], ...]:
    """navground's line obstacles (``LineSegment``, walls of no thickness) as gpcnav's walls
    (:attr:`casadi_gpc.types.Observation.walls`): each segment a polyline of two points. The
    check layer judges every option against them, and the planner plans with them once its
    NLP has wall slots."""
    return tuple(((float(line.p1[0]), float(line.p1[1])), (float(line.p2[0]), float(line.p2[1])))
                 for line in lines if float(np.hypot(*(np.asarray(line.p2) - np.asarray(line.p1)))) > 0.0)


class NeighbourTracks:
    """Ids that last for navground's neighbours.

    navground's state estimations report a neighbour with the id its scenario gave the agent,
    0 unless set, so ids cannot tell neighbours apart; the controllers' obstacle filters need
    one id per obstacle. Each update matches the neighbours to the known ones by distance
    to where those are predicted now (position plus navground's velocity times the time
    since), nearest pairs first, within ``gate_m``; a neighbour left unmatched gets a new
    id, and a known one not seen is forgotten (its filter then misses a measurement).

    Parameters
    ----------
    gate_m : float
        The largest distance (m) between a prediction and a neighbour that is still the
        same obstacle. Agents do not overlap, so their centres are at least two radii
        apart; 0.5 m is above the error of a 0.1 s prediction by far.
    """

    def __init__(self, gate_m: float = 0.5):
        self.gate_m = float(gate_m)
        self.reset()

    def reset(self) -> None:
        self._known: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._next_id = 0

    def update(self, neighbours, dt_s: float) -> tuple[ObstacleMeasurement, ...]:
        """The neighbours (navground ``Neighbor`` s, or anything with ``position``,
        ``velocity``, ``radius``) as measurements with lasting ids, ``dt_s`` after the last
        update."""
        now = [(np.asarray(n.position, dtype=float), np.asarray(n.velocity, dtype=float), float(n.radius))
               for n in neighbours]
        ids = list(self._known)
        predicted = [self._known[i][0] + self._known[i][1] * dt_s for i in ids]
        pairs = sorted((float(np.hypot(*(p - q))), a, b) for a, p in enumerate(predicted)
                       for b, (q, _, _) in enumerate(now))
        taken_known, matched = set(), {}
        for d, a, b in pairs:
            if d > self.gate_m:
                break
            if a not in taken_known and b not in matched:
                taken_known.add(a)
                matched[b] = ids[a]
        known, out = {}, []
        for b, (q, v, r) in enumerate(now):
            if b not in matched:
                matched[b] = self._next_id
                self._next_id += 1
            known[matched[b]] = (q, v)
            out.append(ObstacleMeasurement(matched[b], (float(q[0]), float(q[1])), r))
        self._known = known
        return tuple(out)
