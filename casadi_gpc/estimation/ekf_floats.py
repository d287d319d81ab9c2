"""The obstacle EKF's arithmetic written out on plain floats (:mod:`casadi_gpc.estimation.ekf`).

The deployed policy runs the filter every sample; numpy's per-call cost on 5-vectors and
5x5 matrices, not the arithmetic, was half of its decision time. The covariance travels as
its upper triangle (15 floats, :data:`upper`); the tests hold these forms to the matrix
forms of the textbook filter.
"""
from __future__ import annotations

import math
from operator import itemgetter

import numpy as np
from numba import njit
from numba.extending import register_jitable

__all__ = ["cov_step", "propagate", "forecast_rows", "forecast", "joseph", "correct", "update_rows", "step_rows",
           "frame_rows", "step_frame_rows", "worst_std_rows", "upper", "full", "cov_array", "straight_noise"]

_PI, _TWO_PI = math.pi, 2 * math.pi


def straight_noise(q: tuple) -> tuple:
    """The process noise's diagonal ``q`` (x, y, speed, heading, turn increment) of a straight
    forecast (:func:`casadi_gpc.estimation.obstacle_model.straightened`): the turn increment's entry
    zeroed, so that it neither is held nor wanders; the others kept."""
    return (*q[:4], 0.0)


def cov_step(a: float, b: float, e: float, g: float, U: tuple, q: tuple) -> tuple:
    """One step of the covariance, ``P' = F P F^T + Q``, on P's upper triangle ``U`` (15
    entries row by row, :data:`upper`), for the model's Jacobian F: the identity but for
    ``F[0, 2:] = (a, b, b)``, ``F[1, 2:] = (e, g, g)``, ``F[3, 4] = 1``. With ``w_j = P f_j``
    (``f_j`` the rows of F) the result is ``P'_ij = f_i . w_j``, and only the first two
    columns of P change shape; the rest are sums of its entries.

    Plain arithmetic, the one definition of the step: :func:`propagate` calls it on floats (and
    on CasADi symbols, :mod:`casadi_gpc.estimation.forecast_function`), and the compiled
    forecast (:func:`forecast_rows`) on its own compilation of it."""
    q0, q1, q2, q3, q4 = q
    p00, p01, p02, p03, p04, p11, p12, p13, p14, p22, p23, p24, p33, p34, p44 = U
    # s_k = P[k, 3] + P[k, 4]: the column of the heading, which absorbs the turn increment
    s0, s1, s2, s3, s4 = p03 + p04, p13 + p14, p23 + p24, p33 + p34, p34 + p44
    # w0 = P f_0 (entries 0, 2, 3, 4) and w1 = P f_1
    w00, w02, w03, w04 = (p00 + a * p02 + b * s0, p02 + a * p22 + b * s2, p03 + a * p23 + b * s3,
                          p04 + a * p24 + b * s4)
    w10, w11, w12, w13, w14 = (p01 + e * p02 + g * s0, p11 + e * p12 + g * s1, p12 + e * p22 + g * s2,
                               p13 + e * p23 + g * s3, p14 + e * p24 + g * s4)
    w0h, w1h = w03 + w04, w13 + w14
    return (w00 + a * w02 + b * w0h + q0, w10 + a * w12 + b * w1h, w02, w0h, w04,
            w11 + e * w12 + g * w1h + q1, w12, w1h, w14,
            p22 + q2, s2, p24,
            s3 + s4 + q3, s4,
            p44 + q4)


def propagate(x: float, y: float, v: float, th: float, dth: float, U: tuple, T: float, q: tuple, steps: int,
              means: list | None = None, covs: list | None = None, xp=math) -> tuple[float, float, float, tuple]:
    """``steps`` steps of the model and of the covariance (:func:`cov_step`), on plain
    floats: returns the new ``(x, y, heading)`` and P's upper triangle ``U`` (15 entries row
    by row, :data:`upper`); speed and turn increment do not change. With ``means`` and
    ``covs`` (lists), each step's position and its covariance (xx, xy, xy, yy) are appended.

    Written out because numpy's per-call overhead on 5x5 matrices, not the arithmetic, was
    half of the deployed policy's decision time.

    ``xp``: the module whose ``cos`` and ``sin`` it uses; ``casadi`` with symbolic arguments
    traces these very operations into an expression (:mod:`casadi_gpc.estimation.forecast_function`)."""
    vT = v * T  # v * T * c evaluates (v * T) * c
    cos, sin = xp.cos, xp.sin
    for _ in range(steps):
        th += dth
        c, si = cos(th), sin(th)
        U = cov_step(T * c, -v * T * si, T * si, v * T * c, U, q)
        x, y = x + vT * c, y + vT * si  # obstacle_model_step, written for one state
        if means is not None:
            means += (x, y)
            covs += (U[0], U[1], U[1], U[5])
    return x, y, th, U


_cov_step = njit(cache=True)(cov_step)


@njit("Tuple((float64[:, :, ::1], float64[:, :, :, ::1]))(float64[:, :], float64[:, :], float64, "
      "float64[::1], int64)", cache=True)
def forecast_rows(states, uppers, T, q, steps):  # pragma: no cover (compiled)
    """The predicted positions ``(N, steps, 2)`` and their covariances ``(N, steps, 2, 2)``
    of N filter states ``(x, y, V, theta, dtheta)`` (``(N, 5)``) with their covariances'
    upper triangles (``(N, 15)``): :func:`propagate`'s numbers, the same operations in the
    same order, compiled (numba: 4.5 against 79 us for ten tracks, the closed form in numpy
    that it replaces, and 16 us a track in Python floats; docs/nn-deploy.md, "Time")."""
    n = states.shape[0]
    means = np.empty((n, steps, 2))
    covs = np.empty((n, steps, 2, 2))
    qq = (q[0], q[1], q[2], q[3], q[4])
    for i in range(n):
        x, y, v, th, dth = states[i, 0], states[i, 1], states[i, 2], states[i, 3], states[i, 4]
        u = uppers[i]
        U = (u[0], u[1], u[2], u[3], u[4], u[5], u[6], u[7], u[8], u[9], u[10], u[11], u[12], u[13], u[14])
        vT = v * T
        for k in range(steps):
            th += dth
            c, si = math.cos(th), math.sin(th)
            U = _cov_step(T * c, -v * T * si, T * si, v * T * c, U, qq)
            x, y = x + vT * c, y + vT * si
            means[i, k, 0], means[i, k, 1] = x, y
            covs[i, k, 0, 0], covs[i, k, 0, 1], covs[i, k, 1, 0], covs[i, k, 1, 1] = U[0], U[1], U[1], U[5]
    return means, covs


def forecast(state: tuple, U: tuple, T: float, q: tuple, steps: int) -> tuple[np.ndarray, np.ndarray]:
    """The predicted positions ``(steps, 2)`` and their covariances ``(steps, 2, 2)`` of the
    filter state ``state = (x, y, V, theta, dtheta)`` with P's upper triangle ``U``
    (:func:`forecast_rows` of the one track)."""
    means, covs = forecast_rows(np.array((state,), dtype=float), np.array((U,), dtype=float), float(T),
                                np.array(q, dtype=float), steps)
    return means[0], covs[0]


upper = itemgetter(0, 1, 2, 3, 4, 6, 7, 8, 9, 12, 13, 14, 18, 19, 24)
"""The upper triangle (15 floats, row by row) of a flat symmetric 5x5."""
full = itemgetter(0, 1, 2, 3, 4, 1, 5, 6, 7, 8, 2, 6, 9, 10, 11, 3, 7, 10, 12, 13, 4, 8, 11, 13, 14)
"""The flat symmetric 5x5 (25 floats) of an upper triangle."""


@register_jitable  # a plain Python function, which compiled code may call too (correct)
def joseph(U: tuple, g00: float, g01: float, g11: float, r: float) -> tuple[tuple, tuple]:
    """The EKF's correction of a position measurement (H = [I 0], R = r I) on plain floats:
    the gain ``K = P[:, :2] S^-1`` (rows ``(k_i0, k_i1)``, flat) and the Joseph form
    ``(I - K H) P (I - K H)^T + K R K^T``, computed as ``A = P - K P[:2, :]``, then
    ``N = A - A[:, :2] K^T + r K K^T`` on the upper triangle (so exactly symmetric).

    ``U``: P's upper triangle (:data:`upper`); ``g``: S^-1 (symmetric 2x2). Written out
    entry by entry: loops over rows cost more than the sums (the deployed policy runs this
    every sample)."""
    p00, p01, p02, p03, p04, p11, p12, p13, p14, p22, p23, p24, p33, p34, p44 = U
    # K rows: P[i, :2] S^-1
    k00, k01 = p00 * g00 + p01 * g01, p00 * g01 + p01 * g11
    k10, k11 = p01 * g00 + p11 * g01, p01 * g01 + p11 * g11
    k20, k21 = p02 * g00 + p12 * g01, p02 * g01 + p12 * g11
    k30, k31 = p03 * g00 + p13 * g01, p03 * g01 + p13 * g11
    k40, k41 = p04 * g00 + p14 * g01, p04 * g01 + p14 * g11
    # A = P - K P[:2, :]: the entries N needs (its row's first two and the upper triangle)
    a00, a01, a02, a03, a04 = (p00 - k00 * p00 - k01 * p01, p01 - k00 * p01 - k01 * p11, p02 - k00 * p02 - k01 * p12,
                               p03 - k00 * p03 - k01 * p13, p04 - k00 * p04 - k01 * p14)
    a10, a11, a12, a13, a14 = (p01 - k10 * p00 - k11 * p01, p11 - k10 * p01 - k11 * p11, p12 - k10 * p02 - k11 * p12,
                               p13 - k10 * p03 - k11 * p13, p14 - k10 * p04 - k11 * p14)
    a20, a21, a22, a23, a24 = (p02 - k20 * p00 - k21 * p01, p12 - k20 * p01 - k21 * p11, p22 - k20 * p02 - k21 * p12,
                               p23 - k20 * p03 - k21 * p13, p24 - k20 * p04 - k21 * p14)
    a30, a31, a33, a34 = (p03 - k30 * p00 - k31 * p01, p13 - k30 * p01 - k31 * p11, p33 - k30 * p03 - k31 * p13,
                          p34 - k30 * p04 - k31 * p14)
    a40, a41, a44 = p04 - k40 * p00 - k41 * p01, p14 - k40 * p01 - k41 * p11, p44 - k40 * p04 - k41 * p14
    # N_ij = A_ij - A_i0 K_j0 - A_i1 K_j1 + r (K_i0 K_j0 + K_i1 K_j1), j >= i
    N = (a00 - a00 * k00 - a01 * k01 + r * (k00 * k00 + k01 * k01),
         a01 - a00 * k10 - a01 * k11 + r * (k00 * k10 + k01 * k11),
         a02 - a00 * k20 - a01 * k21 + r * (k00 * k20 + k01 * k21),
         a03 - a00 * k30 - a01 * k31 + r * (k00 * k30 + k01 * k31),
         a04 - a00 * k40 - a01 * k41 + r * (k00 * k40 + k01 * k41),
         a11 - a10 * k10 - a11 * k11 + r * (k10 * k10 + k11 * k11),
         a12 - a10 * k20 - a11 * k21 + r * (k10 * k20 + k11 * k21),
         a13 - a10 * k30 - a11 * k31 + r * (k10 * k30 + k11 * k31),
         a14 - a10 * k40 - a11 * k41 + r * (k10 * k40 + k11 * k41),
         a22 - a20 * k20 - a21 * k21 + r * (k20 * k20 + k21 * k21),
         a23 - a20 * k30 - a21 * k31 + r * (k20 * k30 + k21 * k31),
         a24 - a20 * k40 - a21 * k41 + r * (k20 * k40 + k21 * k41),
         a33 - a30 * k30 - a31 * k31 + r * (k30 * k30 + k31 * k31),
         a34 - a30 * k40 - a31 * k41 + r * (k30 * k40 + k31 * k41),
         a44 - a40 * k40 - a41 * k41 + r * (k40 * k40 + k41 * k41))
    return (k00, k01, k10, k11, k20, k21, k30, k31, k40, k41), N


def correct(x: float, y: float, v: float, th: float, dth: float, U: tuple, zx: float, zy: float, r: float,
            gate: float) -> tuple[bool, tuple, tuple]:
    """The correction of a propagated estimate ``(x, y, v, th, dth)`` with covariance ``U``
    (:data:`upper`) by the position ``(zx, zy)`` measured with variance ``r``, unless the
    innovation's squared Mahalanobis distance is above ``gate``: ``(True, state, U')``, the
    state's heading wrapped to [-pi, pi); or ``(False, state, U)`` unchanged when gated out.

    Plain arithmetic, the one definition of the filter's correction:
    :meth:`~casadi_gpc.estimation.ekf.ObstacleEKF.step` calls it on floats, and the compiled
    update of many filters (:func:`update_rows`) on its own compilation of it."""
    i0, i1 = zx - x, zy - y
    # S = P[:2, :2] + R is 2x2
    s00, s01, s11 = U[0] + r, U[1], U[5] + r
    det = s00 * s11 - s01 * s01
    m2 = (s11 * i0 * i0 - 2.0 * s01 * i0 * i1 + s00 * i1 * i1) / det  # innov^T S^-1 innov
    if m2 > gate:
        return False, (x, y, v, th, dth), U
    # gain K = P[:, :2] S^-1 (rows (k_i0, k_i1)) and the Joseph-form covariance
    K, N = joseph(U, s11 / det, -s01 / det, s00 / det, r)
    k00, k01, k10, k11, k20, k21, k30, k31, k40, k41 = K
    th = th + k30 * i0 + k31 * i1
    return True, (x + k00 * i0 + k01 * i1, y + k10 * i0 + k11 * i1, v + k20 * i0 + k21 * i1,
                  (th + _PI) % _TWO_PI - _PI, dth + k40 * i0 + k41 * i1), N


_correct = njit(cache=True)(correct)


@njit(cache=True)
def _row_update(row, zx, zy, T, qq, r, gate):  # pragma: no cover (compiled)
    """One sample of the initialised filter whose state (5) and covariance's upper triangle (15)
    are ``row[:20]``, measured at ``(zx, zy)``: the step of :func:`propagate` (the same operations
    in the same order), then :func:`correct`. The one compiled step, which :func:`update_rows`
    and :func:`step_rows` run."""
    x, y, v, th, dth = row[0], row[1], row[2], row[3], row[4]
    u = row[5:20]
    U = (u[0], u[1], u[2], u[3], u[4], u[5], u[6], u[7], u[8], u[9], u[10], u[11], u[12], u[13], u[14])
    vT = v * T
    th += dth
    c, si = math.cos(th), math.sin(th)
    U = _cov_step(T * c, -v * T * si, T * si, v * T * c, U, qq)
    x, y = x + vT * c, y + vT * si
    return _correct(x, y, v, th, dth, U, zx, zy, r, gate)


@njit("float64[:, ::1](float64[:, ::1], float64, float64, float64, float64, float64, float64, float64, float64)",
      cache=True)
def update_rows(rows, T, q0, q1, q2, q3, q4, r, gate):  # pragma: no cover (compiled)
    """One sample of N initialised filters, row by row ``rows`` ``(N, 22)``: the state (5),
    the covariance's upper triangle (15) and the measured position (2), all with the same
    sample time, Q diagonal ``q0..q4``, measurement variance ``r`` and ``gate`` (one array
    in and one out: in a decision among walkers each numpy call costs more than the
    arithmetic). The step of :func:`propagate` (the same operations in the same order), then
    :func:`correct`, compiled. Returns ``(N, 21)``: 1.0 where the row was corrected (else
    0.0: gated, the caller leaves it aside), then the new state and triangle
    (``tests/test_ekf_batch.py`` holds it to the filter's own step bit for bit)."""
    n = rows.shape[0]
    out = np.empty((n, 21))
    qq = (q0, q1, q2, q3, q4)
    for i in range(n):
        passed, s, N = _row_update(rows[i], rows[i, 20], rows[i, 21], T, qq, r, gate)
        out[i, 0] = 1.0 if passed else 0.0
        for k in range(5):
            out[i, 1 + k] = s[k]
        for k in range(15):
            out[i, 6 + k] = N[k]
    return out


@njit("float64[::1](float64[:, ::1], float64[:, ::1], float64, float64, float64, float64, float64, float64, float64, "
      "float64)", cache=True)
def step_rows(bank, jobs, T, q0, q1, q2, q3, q4, r, gate):  # pragma: no cover (compiled)
    """One sample of the initialised filters held as rows of ``bank`` (``(capacity, 23)``:
    the state (5), the covariance's upper triangle (15), the last fused position (2) and the
    samples since it (1); :class:`casadi_gpc.estimation.track_rows.RowBank`), in place: ``jobs``
    ``(N, 3)``, the row's index and the measured position. Each row is :func:`update_rows`'
    step; one that passes the gate is written back (its last fused position the measurement, 0
    samples since), one gated out is left as it was. Returns 1.0 where the row was corrected,
    else 0.0 (its filter's own step follows: an outlier, a manoeuvre, a restart)."""
    n = jobs.shape[0]
    passed = np.empty(n)
    qq = (q0, q1, q2, q3, q4)
    for j in range(n):
        i = int(jobs[j, 0])
        zx, zy = jobs[j, 1], jobs[j, 2]
        ok, s, N = _row_update(bank[i], zx, zy, T, qq, r, gate)
        if ok:
            for k in range(5):
                bank[i, k] = s[k]
            for k in range(15):
                bank[i, 5 + k] = N[k]
            bank[i, 20], bank[i, 21], bank[i, 22] = zx, zy, 0.0
        passed[j] = 1.0 if ok else 0.0
    return passed


def _worst_signature(readonly: bool):
    from numba import types
    return types.float64[:, ::1](types.Array(types.float64, 4, "C", readonly=readonly))


@njit([_worst_signature(False), _worst_signature(True)], cache=True)
def worst_std_rows(covs):  # pragma: no cover (compiled)
    """:func:`casadi_gpc.estimation.ekf.worst_std_m` of ``(N, H, 2, 2)`` covariances, ``(N, H)``,
    compiled: ``sqrt(max((a + d) / 2 + hypot((a - d) / 2, b), 0))`` entry by entry, numpy's
    numbers bit for bit (the same libm ``hypot`` and ``sqrt``; ``tests/test_ekf_batch.py``).
    The check reads it for a crowd's forecasts at every decision (some 8 numpy calls)."""
    n, h = covs.shape[0], covs.shape[1]
    out = np.empty((n, h))
    for i in range(n):
        for k in range(h):
            a, b, d = covs[i, k, 0, 0], covs[i, k, 0, 1], covs[i, k, 1, 1]
            out[i, k] = np.sqrt(np.maximum((a + d) * 0.5 + math.hypot((a - d) * 0.5, b), 0.0))
    return out


@njit("Tuple((float64[:, ::1], float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1]))(float64[:, ::1], "
      "int64[::1], float64, float64[::1], int64)", cache=True)
def frame_rows(bank, order, T, q, steps):  # pragma: no cover (compiled)
    """The rows ``order`` of a bank held as rows (:func:`step_rows`), copied out as ``(N, 20)``
    (the state and the covariance's upper triangle), with their forecasts
    (:func:`forecast_rows`) and the forecasts' worst deviations (:func:`worst_std_rows`): one
    call from the bank to what a check reads."""
    n = order.shape[0]
    rows = np.empty((n, 20))
    for j in range(n):
        i = order[j]
        for k in range(20):
            rows[j, k] = bank[i, k]
    means, covs = forecast_rows(rows[:, :5], rows[:, 5:], T, q, steps)
    return rows, means, covs, worst_std_rows(covs)


@njit("Tuple((float64[::1], float64[:, ::1], float64[:, :, ::1], float64[:, :, :, ::1], float64[:, ::1]))("
      "float64[:, ::1], float64[:, ::1], int64[::1], float64, float64[::1], float64, float64, int64)", cache=True)
def step_frame_rows(bank, jobs, order, T, q, r, gate, steps):  # pragma: no cover (compiled)
    """:func:`step_rows` (``q``: the diagonal of Q), then :func:`frame_rows` of the rows
    ``order``, in one call: the flags of :func:`step_rows`, then the rows, their forecasts and
    worst deviations (those of a row gated out are its estimate before the step: its own step
    follows, and the caller makes them again)."""
    passed = step_rows(bank, jobs, T, q[0], q[1], q[2], q[3], q[4], r, gate)
    rows, means, covs, worst = frame_rows(bank, order, T, q, steps)
    return passed, rows, means, covs, worst


def cov_array(U: tuple) -> np.ndarray:
    """The (5, 5) covariance array of an upper triangle."""
    return np.array(full(U)).reshape(5, 5)
