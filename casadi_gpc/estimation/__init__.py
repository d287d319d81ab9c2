"""Estimation: what the robot knows of the moving obstacles.

Rooms: ``obstacle_model`` (the filter's model, noise levels and frozen estimate with its
forecast), ``ekf`` (the extended Kalman filter of one obstacle, numpy), ``ekf_floats`` (its
arithmetic on plain floats, and the forecast compiled with numba), ``ekf_batch`` (the forecasts
of many tracks made together, as arrays), ``forecast_function`` (the forecast traced into a CasADi function from
those floats: the planner's side, the same numbers; imports CasADi, so not imported here)
``tracking`` (the bank of filters, one per obstacle id, and the forecasts planners plan
with) and ``track_rows`` (the deployed policy's bank, its estimates as rows of one array). Everything imported here is numpy and numba only: the deployed policy uses it.
"""
from .ekf import ObstacleEKF
from .obstacle_model import EKFSettings, planning_covariances, worst_std_m
from .tracking import TrackBank

__all__ = ["EKFSettings", "ObstacleEKF", "TrackBank", "planning_covariances", "worst_std_m"]
