"""Which obstacles enter the planner's NLP, and its parameter vector (numpy only).

The NLP has a fixed number of obstacle slots (``PlannerConfig.max_moving`` and
``max_static``). When more obstacles are known, the most relevant fill them:

- a moving obstacle by its **predicted distance to the robot's predicted path**: the
  smallest clearance, over the steps k = 1..H, between its predicted position at step k and
  where the robot is predicted to be at step k (the plan it follows, shifted by one step;
  without one, the desired poses), and between its position at step 1 and the robot now. A
  crowd member that will cross the robot's path matters more than a nearer one walking away.
- a static obstacle by its distance from the robot.

Movers left out although they come within ``PlannerConfig.relevance_range_m`` of the
predicted path are counted by the planner (``left_out``): they are still in the safety
check (:mod:`casadi_gpc.safety`), which sees every obstacle.

The planner (:class:`casadi_gpc.planner.gpc.GPCController`) and the labeller
(:class:`nn_export.training.labels.Labeller`) both choose and pack here, so a change of the
criterion is made once. :func:`goal_weights` marks the desired poses at the end of the path
(the same rule for both).
"""
from __future__ import annotations

import math

import numpy as np

from ..config import PlannerConfig
from ..geometry import a_wall_within, distance_to_segments_m, map_segment_rows, segment_candidates
from ..types import ObstacleForecast, StaticObstacle

__all__ = ["Selection", "select_obstacles", "select_walls", "planner_parameters", "pack_selection", "goal_weights",
           "relevance_m", "near_walls"]


def relevance_m(forecasts, x0: np.ndarray, path_xy: np.ndarray | None) -> np.ndarray:
    """The moving obstacles' predicted clearances to the robot's predicted path (module
    text): centre distances minus each obstacle's radius, m, shape (n,) (smaller is more
    relevant)."""
    q = np.array([f.means_m for f in forecasts], dtype=float)            # (n, H, 2)
    d = np.hypot(q[:, 0, 0] - x0[0], q[:, 0, 1] - x0[1])
    if path_xy is not None:
        k = min(q.shape[1], len(path_xy))
        d = np.minimum(d, np.hypot(q[:, :k, 0] - path_xy[:k, 0], q[:, :k, 1] - path_xy[:k, 1]).min(axis=1))
    return d - np.array([f.radius_m for f in forecasts], dtype=float)


class Selection:
    """What :func:`select_obstacles` chose: the forecasts and static obstacles in the slots,
    how many relevant movers did not fit (``left_out``), the ids of every mover within
    ``relevance_range_m`` of the predicted path (``relevant``), the wall segments in the
    slots (``walls``: ``(ax, ay, bx, by)`` each), how many segments within the relevance
    range did not fit (``walls_left_out``), and whether the margin near walls applies
    (``near_walls``, :func:`planner_parameters`)."""

    __slots__ = ("forecasts", "statics", "left_out", "relevant", "walls", "walls_left_out", "near_walls")

    def __init__(self, forecasts, statics, left_out: int, relevant: frozenset = frozenset(), walls=(),
                 walls_left_out: int = 0, near_walls: bool = False):
        self.forecasts, self.statics, self.left_out, self.relevant = forecasts, statics, left_out, relevant
        self.walls, self.walls_left_out, self.near_walls = walls, walls_left_out, near_walls


def select_walls(x0: np.ndarray, walls, config: PlannerConfig, path_xy: np.ndarray | None = None
                 ) -> tuple[list, int]:
    """The wall segments that fill the NLP's ``max_walls`` slots: every segment of the
    polylines ``walls`` (``(x, y)`` points each), the nearest to the robot's predicted path
    (and to the robot now) first; and how many within ``relevance_range_m`` of it did not
    fit (counted: they are still in the check layer)."""
    if type(walls) is not tuple:  # an Observation's walls are tuples already
        walls = tuple(tuple((float(x), float(y)) for x, y in pts) for pts in walls)
    segs = map_segment_rows(walls, straight=True)  # a straight wall one slot, however it was drawn
    if not len(segs) or config.max_walls == 0:
        return [], 0
    pts = np.asarray(x0[:2], dtype=float)[None] if path_xy is None else np.vstack([x0[:2], np.asarray(path_xy)[:, :2]])
    # a large map: only the segments of the grid's cells round the path, where at least the slots' number lie
    # within relevance_range_m of it (then the nearest, in the same order, and every one left out within that
    # range are among them); else all
    lo, hi, reach = pts.min(axis=0), pts.max(axis=0), config.relevance_range_m
    idx = segment_candidates(segs, *((lo + hi) / 2).tolist(), float((hi - lo).max()) / 2 + reach)
    d = None
    if idx is not None:
        near = segs[idx]
        d = distance_to_segments_m(pts, near[:, :2], near[:, 2:]).min(axis=0)
        if np.count_nonzero(d <= reach) >= config.max_walls:
            segs = near
        else:
            d = None
    if d is None:
        d = distance_to_segments_m(pts, segs[:, :2], segs[:, 2:]).min(axis=0)
    order = np.argsort(d, kind="stable")
    chosen = order[:config.max_walls]
    left_out = int(np.count_nonzero(d[order[config.max_walls:]] < config.relevance_range_m))
    return [tuple(segs[k]) for k in chosen], left_out


def select_obstacles(x0: np.ndarray, forecasts, statics, config: PlannerConfig,
                     path_xy: np.ndarray | None = None) -> Selection:
    """The forecasts and static obstacles that fill the NLP's slots, most relevant first
    when there are more than the slots (else as given).

    Parameters
    ----------
    x0 : array (5,)
        The robot's state now: x (m), y (m), heading (rad), right and left wheel speeds (m/s).
    forecasts : sequence of ObstacleForecast
        The moving obstacles' predicted positions at steps 1..H, m.
    statics : sequence of StaticObstacle
        The static obstacles.
    config : PlannerConfig
        Its ``max_moving`` and ``max_static`` are the slots; ``relevance_range_m`` says
        which movers left out are counted.
    path_xy : array (H, 2), optional
        The robot's predicted positions at steps 1..H (module text); None: the robot now.
    """
    forecasts = list(forecasts)
    left_out, relevant = 0, frozenset()
    if forecasts:
        rel = relevance_m(forecasts, x0, path_xy)
        relevant = frozenset(f.obstacle_id for f, r in zip(forecasts, rel) if r < config.relevance_range_m)
        if len(forecasts) > config.max_moving:
            order = np.argsort(rel, kind="stable")  # ties keep the given order
            left_out = int(np.count_nonzero(rel[order[config.max_moving:]] < config.relevance_range_m))
            forecasts = [forecasts[i] for i in order[: config.max_moving]]
    statics = list(statics)
    if len(statics) > config.max_static:
        statics = sorted(statics, key=lambda s: math.hypot(s.position_m[0] - x0[0], s.position_m[1] - x0[1]))
        statics = statics[: config.max_static]
    return Selection(forecasts, statics, left_out, relevant)


def goal_weights(ref_poses: np.ndarray, config: PlannerConfig) -> np.ndarray | None:
    """Tracking weight factors of the desired poses at steps 1..H: ``config.goal_weight`` at
    the end of the path, 1 elsewhere (None when ``goal_weight`` is 1).

    ``ref_poses``: the desired poses at steps 0..H, shape (H + 1, 3). A desired pose is at
    the end of the path when it equals the one before: the reference point moves on at its
    speed (waiting only with the robot, never in the horizon) and stops only there."""
    if config.goal_weight == 1.0:
        return None
    ref = np.asarray(ref_poses, dtype=float)
    at_end = np.all(ref[1:] == ref[:-1], axis=1)
    return np.where(at_end, float(config.goal_weight), 1.0)


def planner_parameters(layout, x0: np.ndarray, ref_poses: np.ndarray, forecasts, statics, config: PlannerConfig,
                       path_xy: np.ndarray | None = None, walls=(), walls_reach_m: float | None = None
                       ) -> tuple[np.ndarray, Selection]:
    """The NLP parameter vector of one tick and the obstacles in it: :func:`select_obstacles`,
    packed by the problem's parameter ``layout`` (:meth:`casadi_gpc.problem.cost.ParameterLayout.pack`).

    ``ref_poses``: the desired poses ``[x_m, y_m, heading_rad]`` at steps 0..H, shape
    (H + 1, 3) (step 0: where the reference point is now). ``walls``: the map's polylines
    (:attr:`casadi_gpc.types.Observation.walls`), for an NLP with wall slots.
    ``walls_reach_m``: the robot's reach (:func:`casadi_gpc.geometry.walls_reach_m`); where a
    wall segment is within it of the robot, the margin near walls applies
    (:attr:`~casadi_gpc.config.PlannerConfig.walls_margin_m`, where the layout takes it;
    ``Selection.near_walls``). Returns the parameters and the selection.
    """
    sel = select_obstacles(x0, forecasts, statics, config, path_xy)
    if walls and config.max_walls:
        sel.walls, sel.walls_left_out = select_walls(x0, walls, config, path_xy)
    sel.near_walls = near_walls(layout, config, walls, x0, walls_reach_m)
    return pack_selection(layout, x0, ref_poses, sel, config, sel.near_walls), sel


def near_walls(layout, config: PlannerConfig, walls, x0: np.ndarray, reach_m: float | None) -> bool:
    """Whether the margin near walls applies at this tick: the settings have one
    (:attr:`~casadi_gpc.config.PlannerConfig.walls_margin_m`), the NLP's ``layout`` takes it,
    and a segment of ``walls`` comes within the robot's reach ``reach_m``
    (:func:`casadi_gpc.geometry.walls_reach_m`) of where it is, ``x0``. The planner's
    (:func:`planner_parameters`) and the labeller's one rule."""
    return bool(walls) and config.walls_margin_m is not None and reach_m is not None and \
        getattr(layout, "margin", None) is not None and a_wall_within(walls, x0[:2], reach_m)


def pack_selection(layout, x0: np.ndarray, ref_poses: np.ndarray, selection: Selection, config: PlannerConfig,
                   near_walls: bool = False) -> np.ndarray:
    """The NLP parameter vector of a :class:`Selection` made already, packed by ``layout``
    (the part of :func:`planner_parameters` after the choice; ``near_walls``: with the margin
    near walls, as :attr:`Selection.near_walls` says it applies). ``layout`` may have fewer
    slots than ``config`` where the selection fits in them (the labeller solves on such an
    NLP: an empty slot's terms are exact zeros, so the answer is the same). Near walls the
    movers' deviations in the margin are capped by
    :attr:`~casadi_gpc.config.PlannerConfig.walls_sigma_cap_m` where it is set, and taken along
    the line to the robot with :attr:`~casadi_gpc.config.PlannerConfig.walls_directional_sigma`."""
    ref = np.asarray(ref_poses, dtype=float)
    margin = (config.walls_margin_m, config.walls_sigmas) if near_walls else None
    cap = config.walls_sigma_cap_m if near_walls else None
    directional = near_walls and config.walls_directional_sigma and getattr(layout, "directional", False)
    return layout.pack(x0, ref[1:], selection.forecasts, selection.statics, config.uncertainty_scale_m,
                       goal_weights(ref, config), getattr(selection, "walls", ()), margin, cap, directional)
