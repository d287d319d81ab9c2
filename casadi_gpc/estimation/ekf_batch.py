"""The obstacle filter's H-step forecast for many tracks at once (numpy only).

:func:`casadi_gpc.estimation.ekf_floats.propagate` steps one track's mean and covariance H times on
plain floats: about 16 us a track on the 2-core machine, 0.16 ms of a decision among ten
walkers. Here the H steps of N tracks are taken together, in closed form over the
horizon, with a fixed number of array operations whatever N is (about 80 us for ten).

The model (:mod:`casadi_gpc.estimation.ekf`) splits the state into the position ``p = (x, y)`` and
``z = (V, theta, dtheta)``. Its Jacobian at step k is ``F_k = [[I, J_k], [0, G]]`` with
``G = [[1, 0, 0], [0, 1, 1], [0, 0, 1]]`` (constant) and
``J_k = [[T c_k, -V T s_k, -V T s_k], [T s_k, V T c_k, V T c_k]]`` (``c_k, s_k`` the cosine
and sine of ``theta + k dtheta``). With ``P = [[A, B], [B^T, C]]`` and
``Q = diag(Q_p, Q_z)``, ``P' = F P F^T + Q`` reads::

    C_k = G C_{k-1} G^T + Q_z
    B_k = (B_{k-1} + J_k C_{k-1}) G^T
    A_k = A_{k-1} + J_k B_{k-1}^T + B_{k-1} J_k^T + J_k C_{k-1} J_k^T + Q_p

``C`` does not depend on the state, and ``G^m = I + m e_theta e_dtheta^T``, so ``C_k`` is a
polynomial in k and ``B_k``, ``A_k`` are cumulative sums over the steps. The numbers are
:func:`~casadi_gpc.estimation.ekf_floats.propagate`'s up to rounding (the sums are taken in another
order; tested to 1e-12).
"""
from __future__ import annotations

from functools import lru_cache

import numpy as np

from .ekf import _q_diagonal, worst_std_m

__all__ = ["forecast_many", "ForecastBatch", "MANY_TRACKS"]

MANY_TRACKS = 6
"""From this many tracks on, a bank's forecasts are made together (:func:`forecast_many`);
below it the float form costs less. Measured on the 2-core machine, the batch against one
by one (``ForecastBatch.arrays`` against ``FilterState.predict``, 12 steps, medians in one
run): 1.2x the time for 4 tracks, 0.5-0.6x for 10, 0.4x for 20."""


@lru_cache(maxsize=16)
def _rows(horizon: int, q_z: tuple) -> tuple[np.ndarray, ...]:
    """Constants over the steps k = 1..H: k and m = k - 1 (rows, shape (H,)), the noise that
    ``C_{k-1}`` has gathered, ``sum_{i<m} G^i Q_z G^i^T`` (its (V, V), (theta, theta),
    (theta, dtheta) and (dtheta, dtheta) entries; the others are zero), 2 m and m^2, and
    the summing matrices: ``X @ L`` sums the steps up to k, and ``X @ [L, Ls]`` also those
    before it."""
    k = np.arange(1, horizon + 1, dtype=float)
    m = k - 1.0
    q2, q3, q4 = q_z
    L = np.triu(np.ones((horizon, horizon)))
    rows = (k, m, m * q2, m * q3 + q4 * (m - 1.0) * m * (2.0 * m - 1.0) / 6.0, q4 * m * (m - 1.0) / 2.0, m * q4,
            2.0 * m, m * m, L, np.concatenate([L, L - np.eye(horizon)], axis=1))
    for r in rows:
        r.flags.writeable = False
    return rows


def forecast_many(states, uppers, sample_time_s: float, q: tuple, horizon: int) -> tuple[np.ndarray, np.ndarray]:
    """The predicted positions ``(N, H, 2)`` and their covariances ``(N, H, 2, 2)`` at steps
    1..H of N filter states ``(x, y, V, theta, dtheta)`` (``(N, 5)``) with their covariances'
    upper triangles (``(N, 15)``, row by row: :data:`casadi_gpc.estimation.ekf_floats.upper`), all with
    the same sample time and Q diagonal ``q``: :func:`casadi_gpc.estimation.ekf_floats.forecast` of
    each, together.

    Every array below runs over (track, step) as its last two axes, so that each operation
    is one numpy call for all tracks and steps (stacks of 2x3 matrix products, and
    ``np.cumsum``, cost more than these products and sums by matrix)."""
    S = np.asarray(states, dtype=float).reshape(-1, 5).T[:, :, None]     # (5, N, 1)
    U = np.asarray(uppers, dtype=float).reshape(-1, 15).T[:, :, None]    # (15, N, 1)
    T = float(sample_time_s)
    k, m, n_vv, n_hh, n_hw, n_ww, two_m, m2, L, L_Ls = _rows(int(horizon), (float(q[2]), float(q[3]), float(q[4])))
    p00, p01, p02, p03, p04, p11, p12, p13, p14, p22, p23, p24, p33, p34, p44 = U
    th = S[3] + k * S[4]                                   # (N, H): the heading after each step
    N, H = th.shape
    alpha = np.empty((2, N, H))                             # T (cos, sin)
    np.cos(th, out=alpha[0])
    np.sin(th, out=alpha[1])
    vT = S[2] * T
    vcs = vT * alpha                                        # V T (cos, sin): the steps of the means
    alpha *= T
    beta = np.array([-vcs[1], vcs[0]])                      # J_k's rows are (alpha_r, beta_r, beta_r), r = x, y
    # C_{k-1} = G^m C_0 G^m^T + noise, m = k - 1: its V row and D = its theta row + its dtheta row
    c_vh = p23 + m * p24
    c_hw = p34 + m * p44 + n_hw
    Cv = np.array([p22 + n_vv + 0.0 * m, c_vh, p24 + 0.0 * m])
    D = np.array([c_vh + p24, p33 + two_m * p34 + m2 * p44 + n_hh + c_hw, c_hw + (p44 + n_ww)])
    # one summing product for the means, J_k C_{k-1} (Y) and k times its dtheta column
    X = np.empty((10, N, H))
    X[:2] = vcs
    Y = X[2:8].reshape(2, 3, N, H)
    np.multiply(alpha[:, None], Cv, out=Y)
    Y += beta[:, None] * D
    np.multiply(k, Y[:, 2], out=X[8:])
    sums = X.reshape(10 * N, H) @ L_Ls
    means = sums[:2 * N, :H].reshape(2, N, H)
    means += S[:2]
    before = sums[2 * N:, H:].reshape(8, N, H)             # sums over the steps before k
    # B_{k-1} = B_0 G^(k-1)^T + sum_{i<k} Y_i G^(k-i)^T, where X G^j^T adds j X[:, dtheta] to X[:, theta]
    B0 = U[[2, 3, 4, 6, 7, 8]].reshape(2, 3, N, 1)
    theta = m * B0[:, 2] + k * before[[2, 5]] - before[6:]
    Bp = before[:6].reshape(2, 3, N, H)
    Bp += B0
    Bp[:, 1] += theta
    # J_k B_{k-1}^T (Z[r, s]) and J_k C_{k-1} J_k^T (W[r, s] = Y_r . J_s, symmetric)
    Z = alpha[:, None] * Bp[None, :, 0] + beta[:, None] * (Bp[None, :, 1] + Bp[None, :, 2])
    inc = Y[:, None, 0] * alpha[None] + (Y[:, None, 1] + Y[:, None, 2]) * beta[None]
    inc += Z
    inc += Z.transpose(1, 0, 2, 3)
    inc[0, 0] += q[0]
    inc[1, 1] += q[1]
    A = (inc.reshape(4 * N, H) @ L).reshape(2, 2, N, H)
    A += U[[0, 1, 1, 5]].reshape(2, 2, N, 1)
    return np.ascontiguousarray(means.transpose(1, 2, 0)), np.ascontiguousarray(A.transpose(2, 3, 0, 1))


class ForecastBatch:
    """The H-step forecasts of several filters' frozen estimates
    (:class:`~casadi_gpc.estimation.ekf.FilterState`, from one bank: same sample time and settings),
    made together when first read: :meth:`FilterState.predict
    <casadi_gpc.estimation.ekf.FilterState.predict>`'s numbers up to rounding, one row per estimate.
    Estimates seen once (standing, their own forecast) are made one by one."""

    __slots__ = ("snapshots", "horizon", "_arrays", "_planning", "_worst")

    def __init__(self, snapshots, horizon: int):
        self.snapshots, self.horizon = tuple(snapshots), int(horizon)
        self._arrays = self._planning = self._worst = None

    def __len__(self) -> int:
        return len(self.snapshots)

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """Means ``(N, H, 2)`` and covariances ``(N, H, 2, 2)``, read-only."""
        if self._arrays is None:
            snaps, H = self.snapshots, self.horizon
            s0 = snaps[0]
            means, covs = forecast_many([s.state for s in snaps], [s.cov_upper for s in snaps], s0.sample_time_s,
                                        _q_diagonal(s0.settings, s0.sample_time_s), H)
            st, T = s0.settings, s0.sample_time_s
            for i, s in enumerate(snaps):
                if s.measurements_seen < 2 or (s.settings is not st and s.settings != st) or s.sample_time_s != T:
                    means[i], covs[i] = s.predict(H)  # standing, or another filter's noise: its own
            means.flags.writeable = covs.flags.writeable = False
            self._arrays = means, covs
        return self._arrays

    @property
    def planning_covs(self) -> np.ndarray:
        """The covariances a planner plans with (:func:`~casadi_gpc.estimation.ekf.planning_covariances`
        of each row), read-only."""
        if self._planning is None:
            covs = self.arrays[1]
            once = [i for i, s in enumerate(self.snapshots) if s.measurements_seen < 2]
            if once:
                covs = covs.copy()
                covs[once] = covs[once, :1]
                covs.flags.writeable = False
            self._planning = covs
        return self._planning

    @property
    def worst_std_m(self) -> np.ndarray:
        """:func:`~casadi_gpc.estimation.ekf.worst_std_m` of :attr:`planning_covs`, ``(N, H)``, read-only
        (the check's touching distances widen by it)."""
        if self._worst is None:
            w = worst_std_m(self.planning_covs)
            w.flags.writeable = False
            self._worst = w
        return self._worst
