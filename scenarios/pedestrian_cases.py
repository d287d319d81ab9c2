"""The case protocol: scenarios for our robot among the people of a recording.

Adapted from G-MPC's (Wang, Mavrogiannis, Steinfeld, CoRL 2021; its
``test_case_generation.py``) to our robot, which is slower and larger than theirs, and to
recordings it has not seen (no hand-picked region per scene). docs/pedestrians.md gives the
reasons; in short:

1. **Where.** The focus region is the :data:`REGION_SIDE_M` square (G-MPC's 6 m) centred on
   the busiest place of the recording: the 1 m cell, smoothed over its 3 x 3 neighbourhood,
   where people were found most often (sampled every :data:`CANDIDATE_EVERY_S`).
2. **Which way.** The flow is the principal axis of the people's velocities. The robot's
   reference is a straight line of :data:`PATH_LENGTH_M` through the region's centre, along
   the flow or across it, each both ways (G-MPC's four tasks: two crossing, two following).
3. **When.** Every :data:`CANDIDATE_EVERY_S` (G-MPC's 3 s) an instant is a candidate; it
   makes a case when at least :data:`MIN_PEOPLE` people (G-MPC's 5) are inside the region
   then. The robot starts so that its reference point, at :data:`REFERENCE_SPEED_MPS` (the
   speed of every suite here; G-MPC's robot drives 1.75 m/s, ours reaches 0.8 m/s), reaches
   the centre at that instant. A start with someone within :data:`START_CLEARANCE_M` of the
   robot's disc is dropped (G-MPC: 1 m between centres), and so is one where someone appears
   that near within :data:`APPEAR_WITHIN_S` (a person who enters the recording on the robot).
4. **How long.** :data:`DURATION_S` = three times the nominal 20 s (CrowdNav's ratio; G-MPC
   allows six times, for a robot that needs no detour to be fast).
5. **Who.** Every track that overlaps the case's time, cut to it (a row interpolated at each
   end), times from the case's start; discs of :data:`PEDESTRIAN_RADIUS_M`. Sensing: 0.02 m
   noise (the suites'), within :data:`SENSING_RANGE_M` of the robot.

``behaviour`` ``replay`` replays the people open loop; ``orca`` / ``social_force`` makes
them walkers that follow their recording and give way to the robot (``sees_robot``: G-MPC's
reactive mode).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState

from .model import TRACK_BEHAVIOURS, Scenario, Sensing, TrackSpec
from .recordings import Recording

__all__ = ["CaseSpec", "cases", "case_scenario", "TASKS", "PEDESTRIAN_RADIUS_M",
           "REGION_SIDE_M", "PATH_LENGTH_M", "REFERENCE_SPEED_MPS", "DURATION_S", "MIN_PEOPLE",
           "CANDIDATE_EVERY_S", "START_CLEARANCE_M", "APPEAR_WITHIN_S", "SENSING_RANGE_M"]

PEDESTRIAN_RADIUS_M = 0.25
"""A person's disc: half a typical shoulder width (0.45-0.5 m)."""
REGION_SIDE_M = 6.0
PATH_LENGTH_M = 8.0
REFERENCE_SPEED_MPS = 0.4
DURATION_S = 60.0
MIN_PEOPLE = 5
CANDIDATE_EVERY_S = 3.0
START_CLEARANCE_M = 0.5
APPEAR_WITHIN_S = 1.0
"""Someone whose track starts this soon after a case's start, within :data:`START_CLEARANCE_M`
of the robot's disc, blocks the start as someone there at the start does (the ghost time of
``collided_robot_approaching``: nothing avoids a person who appears on it)."""
SENSING_RANGE_M = 8.0
NOISE_STD_M = 0.02
TASKS = ("along", "along-back", "across", "across-back")
"""Following the flow (both ways) and crossing it (both ways)."""


@dataclass(frozen=True)
class CaseSpec:
    """One case: the recording, the task, when the robot starts in the recording's time, and
    the robot's start and goal."""

    recording: str
    task: str
    index: int
    start_s: float
    start_xy: tuple[float, float]
    goal_xy: tuple[float, float]

    @property
    def name(self) -> str:
        return f"{self.recording}-{self.task}-{self.index:03d}"


def _busiest_point(rec: Recording) -> np.ndarray:
    """The centre of the 1 m cell with the most people (every 3 s) in it and its eight
    neighbours; on a tie, the first by x, then y. Counted over the occupied cells only, so a
    stray row kilometres away costs nothing (a dense grid over every position asked 75 GB for
    one person 100 km off: found by an audit)."""
    times = np.arange(rec.start_s, rec.end_s, CANDIDATE_EVERY_S)
    pts = np.concatenate([rec.positions_at(t) for t in times] + [np.zeros((0, 2))])
    lo = np.floor(pts.min(axis=0))
    cells, counts = np.unique(np.floor(pts - lo).astype(np.int64), axis=0, return_counts=True)
    smooth: dict[tuple[int, int], int] = {}
    for (i, j), c in zip(cells.tolist(), counts.tolist()):
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                smooth[(i + dx, j + dy)] = smooth.get((i + dx, j + dy), 0) + c
    top = max(smooth.values())
    i, j = min(k for k, c in smooth.items() if c == top)
    return lo + np.array([i, j]) + 0.5


def _flow_axis(rec: Recording) -> np.ndarray:
    # (with an absurd --seconds-per-frame, rows 1e-299 s apart, the speeds overflow: numpy's
    # warnings made the one-line refusal five lines; such speeds are left out)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        v = np.concatenate([np.diff(tr[:, 1:], axis=0) / np.diff(tr[:, 0])[:, None] for tr in rec.tracks])
        v = v[np.all(np.isfinite(v), axis=1)]
        m = v.T @ v
        if not np.all(np.isfinite(m)):  # the same axis, from speeds scaled down
            v = v / np.abs(v).max()
            m = v.T @ v
    w, vecs = np.linalg.eigh(m)
    axis = vecs[:, int(np.argmax(w))]
    return axis if axis[0] > 0 or (axis[0] == 0 and axis[1] > 0) else -axis  # a fixed sign: reproducible


def _start_blocked(rec: Recording, t0: float, start: np.ndarray, firsts: np.ndarray) -> str | None:
    """Why the robot cannot start at ``start`` at ``t0``: ``"occupied"`` (someone within
    :data:`START_CLEARANCE_M` of its disc then), ``"appears"`` (someone appears that near within
    :data:`APPEAR_WITHIN_S`: until 2026-12-02 only those in the scene at ``t0`` were looked at), or None.
    ``firsts``: every track's first row."""
    near = RobotParams().radius_m + PEDESTRIAN_RADIUS_M + START_CLEARANCE_M
    people = rec.positions_at(t0)
    if people.size and np.hypot(*(people - start).T).min() < near:
        return "occupied"
    soon = firsts[(firsts[:, 0] > t0) & (firsts[:, 0] <= t0 + APPEAR_WITHIN_S), 1:]
    return "appears" if soon.size and np.hypot(*(soon - start).T).min() < near else None


def cases(rec: Recording, skipped: dict | None = None) -> list[CaseSpec]:
    """Every case of the protocol in ``rec``, task by task, in time order. ``skipped``, a dict
    if given, counts the instants dropped for a blocked start by reason (:func:`_start_blocked`)."""
    centre = _busiest_point(rec)
    along = _flow_axis(rec)
    across = np.array([-along[1], along[0]])
    half = REGION_SIDE_M / 2
    to_centre_s = 0.5 * PATH_LENGTH_M / REFERENCE_SPEED_MPS
    instants = np.arange(rec.start_s, rec.end_s, CANDIDATE_EVERY_S)
    firsts = np.array([tr[0] for tr in rec.tracks], dtype=float).reshape(-1, 3)
    busy = [t for t in instants
            if np.sum(np.all(np.abs(rec.positions_at(t) - centre) < half, axis=1)) >= MIN_PEOPLE]
    out = []
    for task, direction in zip(TASKS, (along, -along, across, -across)):
        start = centre - 0.5 * PATH_LENGTH_M * direction
        goal = centre + 0.5 * PATH_LENGTH_M * direction
        k = 0
        for t in busy:
            t0 = t - to_centre_s
            if t0 < rec.start_s:
                continue
            blocked = _start_blocked(rec, t0, start, firsts)
            if blocked:
                if skipped is not None:
                    skipped[blocked] = skipped.get(blocked, 0) + 1
                continue
            out.append(CaseSpec(rec.name, task, k, float(t0), (float(start[0]), float(start[1])),
                                (float(goal[0]), float(goal[1]))))
            k += 1
    return out


CUT_TOLERANCE_S = 1e-4
"""A row this close to a cut is the cut's own (interpolated) row: the files keep times to
0.1 ms (:func:`case_scenario` rounds to 4 decimals)."""


def _cut(track: np.ndarray, t0: float, t1: float) -> np.ndarray | None:
    """The rows of ``track`` within ``[t0, t1]``, with a row interpolated at each end it
    crosses, times from ``t0``; None when fewer than two rows remain. A row within
    :data:`CUT_TOLERANCE_S` of a cut is replaced by the cut's row: a case's start computed
    as the recording's start plus whole seconds lands a few 1e-15 s before a row (every case
    of ``crowds_zara02`` whose start is on a row), and that row, kept beside the cut's,
    rounded to the same time and the whole person was dropped from the case (until
    2026-11-30: 769 people in 70 of its 243 cases, among them people in the scene at the
    start)."""
    t = track[:, 0]
    if t[-1] <= t0 or t[0] >= t1:
        return None
    inside = track[(t > t0 + CUT_TOLERANCE_S) & (t < t1 - CUT_TOLERANCE_S)]
    rows = []
    if t[0] <= t0 + CUT_TOLERANCE_S:
        rows.append([t0, np.interp(t0, t, track[:, 1]), np.interp(t0, t, track[:, 2])])
    rows.extend(inside.tolist())
    if t[-1] >= t1 - CUT_TOLERANCE_S:
        rows.append([t1, np.interp(t1, t, track[:, 1]), np.interp(t1, t, track[:, 2])])
    rows = np.array(rows, dtype=float).reshape(-1, 3)
    if len(rows) < 2:
        return None
    rows[:, 0] -= t0
    return rows


def case_scenario(rec: Recording, case: CaseSpec, behaviour: str = "replay", seed: int = 0) -> Scenario:
    """The :class:`Scenario` of one case; ``behaviour`` as :data:`~scenarios.model.TRACK_BEHAVIOURS`
    (``orca`` and ``social_force`` see the robot)."""
    if behaviour not in TRACK_BEHAVIOURS:
        raise ValueError(f"unknown behaviour {behaviour!r} (choose from {', '.join(TRACK_BEHAVIOURS)})")
    heading = math.atan2(case.goal_xy[1] - case.start_xy[1], case.goal_xy[0] - case.start_xy[0])
    reference = ReferencePath(case.start_xy, heading, (Segment.line(PATH_LENGTH_M),), REFERENCE_SPEED_MPS)
    movers = []
    for track in rec.tracks:
        rows = _cut(track, case.start_s, case.start_s + DURATION_S)
        if rows is None:
            continue
        rows = np.round(rows, 4)
        # rows closer than 0.1 ms (a tiny --seconds-per-frame) rounded to one time: the first of
        # them (the whole person was dropped)
        rows = rows[np.concatenate([[True], np.diff(rows[:, 0]) > 0])]
        if len(rows) < 2:
            continue
        movers.append(TrackSpec(PEDESTRIAN_RADIUS_M, tuple(map(tuple, rows.tolist())), behaviour,
                                behaviour != "replay"))
    suffix = "" if behaviour == "replay" else f"-{behaviour}"
    return Scenario(case.name + suffix, DURATION_S, RobotState(case.start_xy[0], case.start_xy[1], heading),
                    reference, RobotParams(), tuple(movers), (), Sensing(NOISE_STD_M, int(seed), SENSING_RANGE_M),
                    description=f"{rec.name}: {case.task}, from {case.start_s:.1f} s of the recording "
                                f"(case protocol of scenarios.pedestrian_cases)")
