"""Which obstacles enter the planner's NLP, and its parameter vector (numpy only).

The NLP has a fixed number of obstacle slots (``PlannerConfig.max_moving`` and
``max_static``). When more obstacles are known, the nearest fill them: a moving obstacle by
the smallest distance from the robot now to its predicted positions (steps 1..H), a static
one by its distance from the robot. The planner (:class:`casadi_gpc.gpc.GPCController`)
and the labeller (:class:`nn_export.training.labels.Labeller`) both choose and pack here,
so a change of the criterion is made once.
"""
from __future__ import annotations

import math

import numpy as np

from .config import PlannerConfig
from .types import ObstacleForecast, StaticObstacle

__all__ = ["select_obstacles", "planner_parameters"]


def select_obstacles(x0: np.ndarray, forecasts, statics, config: PlannerConfig
                     ) -> tuple[list[ObstacleForecast], list[StaticObstacle]]:
    """The forecasts and static obstacles that fill the NLP's slots, nearest first when
    there are more than the slots (else as given).

    Parameters
    ----------
    x0 : array (5,)
        The robot's state now: x (m), y (m), heading (rad), right and left wheel speeds (m/s).
    forecasts : sequence of ObstacleForecast
        The moving obstacles' predicted positions at steps 1..H, m.
    statics : sequence of StaticObstacle
        The static obstacles.
    config : PlannerConfig
        Its ``max_moving`` and ``max_static`` are the slots.
    """
    forecasts = list(forecasts)
    if len(forecasts) > config.max_moving:
        forecasts = sorted(forecasts, key=lambda f: np.min(np.hypot(*(f.means_m - x0[:2]).T)))[: config.max_moving]
    statics = list(statics)
    if len(statics) > config.max_static:
        statics = sorted(statics, key=lambda s: math.hypot(s.position_m[0] - x0[0], s.position_m[1] - x0[1]))
        statics = statics[: config.max_static]
    return forecasts, statics


def planner_parameters(layout, x0: np.ndarray, ref_poses: np.ndarray, forecasts, statics, config: PlannerConfig
                       ) -> tuple[np.ndarray, list[ObstacleForecast], list[StaticObstacle]]:
    """The NLP parameter vector of one tick and the obstacles in it: :func:`select_obstacles`,
    packed by the problem's parameter ``layout`` (:meth:`casadi_gpc.cost.ParameterLayout.pack`).

    ``ref_poses``: the desired poses ``[x_m, y_m, heading_rad]`` at steps 1..H, shape (H, 3).
    Returns the parameters and the selected forecasts and static obstacles.
    """
    forecasts, statics = select_obstacles(x0, forecasts, statics, config)
    return layout.pack(x0, ref_poses, forecasts, statics, config.uncertainty_scale_m), forecasts, statics
