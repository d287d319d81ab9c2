"""The obstacles of one check: the forecasts stacked as arrays (taken whole from a crowd's
batch when they have one) and their positions and touching distances at the check's
instants (numpy only; see :mod:`casadi_gpc.safety`)."""
from __future__ import annotations

import numpy as np

from ..estimation.obstacle_model import planning_covariances, worst_std_m
from .walls import wall_label

__all__ = ["Obstacles", "forecast_covariances", "forecast_arrays", "shared_batch"]


def forecast_covariances(f) -> np.ndarray:
    """The forecast covariances the check uses: the planner's (a track seen once keeps its
    next step's uncertainty; objects without ``initialised`` are estimated tracks)."""
    return planning_covariances(f.covs_m2, getattr(f, "initialised", True))


def shared_batch(forecasts):
    """The :class:`~casadi_gpc.estimation.ekf_batch.ForecastBatch` whose rows ``forecasts`` are, in its
    order (a crowd's track estimates carry ``batch_`` and ``batch_index_``), else None."""
    batch = getattr(forecasts[0], "batch_", None) if forecasts else None
    if batch is None or len(forecasts) != len(batch):
        return None
    i = 0
    for f in forecasts:
        if getattr(f, "batch_", None) is not batch or f.batch_index_ != i:
            return None
        i += 1
    return batch


def forecast_arrays(forecasts) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The means ``(n, H, 2)``, :func:`forecast_covariances` ``(n, H, 2, 2)`` and their
    :func:`~casadi_gpc.estimation.ekf.worst_std_m` ``(n, H)`` of ``forecasts``, stacked; taken whole
    from their :func:`shared_batch` when they have one. Raises ValueError when their lengths
    differ."""
    batch = shared_batch(forecasts)
    if batch is not None:
        return batch.arrays[0], batch.planning_covs, batch.worst_std_m
    m = np.array([f.means_m for f in forecasts], dtype=float)
    c = np.array([forecast_covariances(f) for f in forecasts], dtype=float)
    return m, c, worst_std_m(c)


class Obstacles:
    """The obstacles of one check at the sample instants, with their sub-sampled form made
    once when a roll-out needs it."""

    __slots__ = ("q", "touch", "radii", "moving", "statics", "walls", "memo", "_filter", "_sub")

    def __init__(self, q, touch, moving, statics, flt, radii=None, walls=None):
        self.q, self.touch, self.moving, self.statics, self._filter, self._sub = q, touch, moving, statics, flt, None
        self.radii = np.ascontiguousarray(touch[:, 0] if radii is None else radii)
        """``(n,)`` the distance at which the robot touches each obstacle's disc, not inflated."""
        self.walls = _NO_WALLS if walls is None else walls
        self.memo: dict = {}
        """What a check has found for these obstacles already (the way out after a command)."""
        """``(nw, 2)`` complex: the wall segments' ends (:mod:`casadi_gpc.safety.walls`), indexed
        after the discs."""

    def sub_samples(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions ``(n, H * substeps + 1)`` and touching distances ``(n, H * substeps)``."""
        if self._sub is None:
            f = self._filter
            self._sub = (self.q @ f._interp, np.repeat(self.touch, f.substeps, axis=1))
        return self._sub

    def label(self, j: int) -> str:
        n, n_discs = len(self.moving), len(self.q)
        if j >= n_discs:
            return wall_label(j - n_discs)
        return f"moving {self.moving[j].obstacle_id}" if j < n else f"static {j - n}"


_NO_WALLS = np.zeros((0, 2), dtype=complex)  # empty: nothing to write
