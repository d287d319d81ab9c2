"""The walls as a network reads them: a scan of the map's wall segments around the robot, as a
range sensor would return it (numpy only).

The plane around the robot is cut into ``n`` equal sectors, sector ``k`` centred on the
direction ``k * 2 pi / n`` in the robot's frame (0 straight ahead, angles counter-clockwise:
sector 1 is ahead and to the left), each ``2 pi / n`` wide. A sector's value is the distance
from the robot's centre to the nearest point of any wall segment inside the sector, capped at
``range_m`` (nothing within range: ``range_m``). This is a laser scan reduced by its minimum
over each sector, computed exactly from the map: a door post between two ray directions is
still seen, at its true distance, in the sector that holds it.

Computed exactly from the map by :func:`casadi_gpc.geometry.wall_scan` (the one definition; the
walkers' learned forecast reads the same scan).

Mirror symmetry: reflecting the world about the robot's heading maps the direction of sector
``k`` to that of sector ``(n - k) mod n``, so the mirror map of the features is a permutation
of the sectors (:mod:`nn_export.runtime.layouts`).
"""
from __future__ import annotations

import math

import numpy as np

from casadi_gpc.geometry import segment_rows as wall_segment_rows  # the walls' segments as (ax, ay, bx, by) rows
from casadi_gpc.geometry import map_segment_rows, segments_near
from casadi_gpc.geometry import wall_scan as _scan

__all__ = ["WALL_SECTORS", "WALL_SCAN_RANGE_M", "DISC_SIDES", "wall_segment_rows", "map_rows", "static_wall_rows",
           "scan_rows", "segments_near", "wall_scan", "sector_mirror"]

WALL_SECTORS = 24
"""Sectors of the scan (15 degrees each: at 2 m a sector is 0.52 m wide, less than a door)."""
WALL_SCAN_RANGE_M = 4.0
"""Walls farther than this from the robot's centre are not in the scan (the ``improved``
planner's obstacle terms reach 1.5 m from the robot's disc, its path 4.8 m in a horizon at top
speed; within 4 m the network sees every wall the planner's plan could meet in the next
seconds)."""


DISC_SIDES = 8
"""Sides of the polygon a static disc is drawn as in the scan (:func:`static_wall_rows`): its
edges stay within 8 % of the radius outside the disc."""


def map_rows(walls) -> np.ndarray:
    """The map's walls as segment rows (:func:`wall_segment_rows`), read-only: what a policy keeps
    for its map, so that a map of hundreds of segments and more is read through its grid
    (:func:`casadi_gpc.geometry.segment_candidates`: the same rows, fewer measured). An
    observation's walls (tuples) share the array the check and the planner read
    (:func:`casadi_gpc.geometry.map_segment_rows`), and its grid."""
    if type(walls) is tuple:
        return map_segment_rows(walls)
    rows = wall_segment_rows(walls).copy()  # an array of its own memory (segment_rows' is a reshaped view)
    rows.flags.writeable = False
    return rows


def static_wall_rows(statics, sides: int = DISC_SIDES) -> np.ndarray:
    """Static discs (``position_m``, ``radius_m``) as wall segments ``(ax, ay, bx, by)``: each
    the closed regular polygon of ``sides`` edges drawn round it (its edges touch the disc), so
    that a scan sees a pillar as a range sensor would, nearest point within ``1 / cos(pi /
    sides) - 1`` of the radius of the disc's own. ``(0, 4)`` for none."""
    rows = []
    half = math.pi / sides
    for st in statics:
        (cx, cy), r = st.position_m, float(st.radius_m) / math.cos(half)
        pts = [(cx + r * math.cos(2 * half * k), cy + r * math.sin(2 * half * k)) for k in range(sides + 1)]
        rows += [(*a, *b) for a, b in zip(pts[:-1], pts[1:])]
    return np.array(rows, dtype=float).reshape(-1, 4)


def scan_rows(wall_rows: np.ndarray, statics, disc_rows: np.ndarray | None = None) -> tuple[np.ndarray, tuple]:
    """What a walls network reads of a map with walls and static discs: the wall segments
    ``wall_rows`` with each disc drawn in as the polygon round it (:func:`static_wall_rows`;
    ``disc_rows``: those rows when the caller keeps them), and no static disc left for its
    slots. The one rule for the deployed policy's decisions and roll-outs
    (``OnnxPolicy(statics_as_walls=True)``, the default) and for the samples it is trained on
    (:func:`~nn_export.runtime.features.feature_values` of a ``set-walls`` layout in a
    situation with walls), so that a pillar reaches the network as its training showed it.
    ``(wall_rows, statics)`` unchanged where there is no static disc."""
    if not statics:
        return wall_rows, statics
    return np.concatenate((wall_rows, static_wall_rows(statics) if disc_rows is None else disc_rows)), ()


def wall_scan(rows: np.ndarray, x: float, y: float, heading: float, n: int = WALL_SECTORS,
              range_m: float = WALL_SCAN_RANGE_M) -> list[float]:
    """The scan of the module docstring for the robot at ``(x, y)`` facing ``heading`` (rad):
    ``n`` distances (m), sector 0 first (:func:`casadi_gpc.geometry.wall_scan`, the one
    definition, with the networks' sectors and range). ``rows``: wall segments ``(ax, ay, bx,
    by)`` (:func:`wall_segment_rows`), in the world frame."""
    return _scan(rows, x, y, heading, n, range_m)


def sector_mirror(n: int) -> np.ndarray:
    """The permutation of the sectors under the mirror map: sector ``k`` of the mirrored
    world is sector ``(n - k) mod n`` of this one."""
    return (-np.arange(n)) % n
