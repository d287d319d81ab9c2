"""The obstacle filter's H-step forecast as a CasADi function: the planner's side.

The planner forecasts every tracked mover at every tick (its relevance, parameters and
check layer read them all). In plain Python floats (:func:`casadi_gpc.estimation.ekf_floats.propagate`)
the 12-step forecast costs about 42 us a mover (with its arrays), most of a crowd decision's
estimation. Traced once into a CasADi expression, by calling that same function with
symbols, and evaluated by CasADi's virtual machine through a buffer, it costs 13 us (a
third; the two measured in one process on the 2-core machine, and 0.69 -> 0.40 ms of a
10-walker crowd decision's estimation, docs/crowds.md), with the same operations in the
same order: the numbers are the same bit for bit (tested). The deployed network policy,
numpy only, keeps the float form. From :data:`~casadi_gpc.estimation.ekf_batch.MANY_TRACKS`
tracks on, the planner's bank forecasts them together in one compiled call instead
(:meth:`~casadi_gpc.estimation.tracking.TrackBank.forecasts`, the same numbers again: among 30
walkers the estimation went from 0.62 to 0.39 ms median).
"""
from __future__ import annotations

from functools import lru_cache

import casadi as ca
import numpy as np

from ..buffered import BufferedFunction
from .ekf_floats import forecast, propagate

__all__ = ["ForecastFunction"]


@lru_cache(maxsize=8)
def _traced(sample_time_s: float, horizon: int) -> ca.Function:
    """The forecast traced once a process for each sample time and horizon (tracing costs
    about 45 ms: a thousand symbolic operations made one by one from Python)."""
    x = ca.SX.sym("x", 25)  # the state, the covariance's upper triangle, Q's diagonal: one write a call
    means, covs = [], []
    propagate(*(x[i] for i in range(5)), tuple(x[i] for i in range(5, 20)), sample_time_s,
              tuple(x[i] for i in range(20, 25)), horizon, means, covs, xp=ca)
    return ca.Function("obstacle_forecast", [x], [ca.vertcat(*means, *covs)], ["state_cov_q"], ["means_covs"])


class ForecastFunction:
    """``forecast(state, cov_upper, T, q, horizon) -> (means (H, 2), covs (H, 2, 2))``: what
    :meth:`casadi_gpc.estimation.obstacle_model.FilterState.predict` computes for a track seen twice or more, for
    one sample time and horizon (another sample time or horizon: the float form)."""

    def __init__(self, sample_time_s: float, horizon: int):
        self.sample_time_s, self.horizon = float(sample_time_s), int(horizon)
        self._fn = BufferedFunction(_traced(self.sample_time_s, self.horizon))  # its own memory
        self._in, self._out = self._fn.inputs[0], self._fn.outputs[0]
        self._eval = self._fn._eval  # plain arithmetic: no error flag to read

    def __call__(self, state: tuple, cov_upper: tuple, T: float, q: tuple,
                 horizon: int) -> tuple[np.ndarray, np.ndarray]:
        H = self.horizon
        if horizon != H or T != self.sample_time_s:
            return forecast(state, cov_upper, T, q, horizon)
        self._in[:] = state + cov_upper + q
        self._eval()
        out = self._out.copy()
        return out[:2 * H].reshape(H, 2), out[2 * H:].reshape(H, 2, 2)
