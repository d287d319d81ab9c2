"""The check's distances, compiled (numba): the closest approach of the robot to each
obstacle disc and each wall segment on every chord of its roll-outs, and what the check reads
off them (the smallest clearance and where, how long the margin is kept, how long the
expected discs are not touched), in one call for all sequences, obstacles and chords; and the
point-to-segment distance they are built on: the compiled form, for these kernels, of
:func:`casadi_gpc.geometry.distance_to_segments_m` (numba cannot call the numpy one;
``tests/test_walls.py`` holds the two to 1e-12 m).

In numpy the same took some 40 whole-array calls a check (their per-call cost, not the
arithmetic, was most of the deployed decision's time among ten walkers: 0.3-0.5 ms a check
that needed the roll-outs); here the arithmetic of each chord is written once, in the order
the numpy form took it (tested against it and against brute force).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types, vectorize

from ..robot import robot_step_compiled as _robot_step  # the robot model's float form, compiled

__all__ = ["rollouts", "segment_distance", "point_segment_distance", "chord_segment_distance", "closest_on_segment",
           "chord_clearances", "path_segment_distances", "screen_obstacles", "reach_bound", "chord_bound", "escape_bounds", "approach"]


@njit("complex128[:, ::1](float64[::1], float64[:, :, ::1], float64[::1], float64, float64)", cache=True)
def rollouts(state, wheels, tau, T, W):  # pragma: no cover (compiled)
    """Robot positions at the sub-sample instants ``tau`` (``(S,)``, s into each interval)
    of each wheel-speed sequence ``wheels`` (``(M, H, 2)``) from ``state`` (x, y, heading,
    ...), as ``x + iy``, ``(M, H * S + 1)``, the first column now: the robot model
    (:func:`~casadi_gpc.robot.robot_step_float`) from each interval's start, the heading there
    the state's plus the turns before it, the start the sum of the intervals' displacements."""
    M, H, S = wheels.shape[0], wheels.shape[1], tau.shape[0]
    p = np.empty((M, H * S + 1), np.complex128)
    p0 = complex(state[0], state[1])
    for m in range(M):
        p[m, 0] = p0
        acc_turn, acc = 0.0, 0j
        for k in range(H):
            vr, vl = wheels[m, k, 0], wheels[m, k, 1]
            turn = (vr - vl) * (T / W)
            acc_turn += turn
            h0 = (state[2] - turn) + acc_turn
            start = 0j
            for s in range(S):
                dx, dy, _ = _robot_step(0.0, 0.0, h0, vr, vl, tau[s], W)
                d = complex(dx, dy)
                if s == S - 1:
                    acc += d
                    start = (p0 - d) + acc
                p[m, 1 + k * S + s] = d
            for s in range(S):
                p[m, 1 + k * S + s] = start + p[m, 1 + k * S + s]
    return p


@njit("float64(float64, float64)", cache=True, inline="always")
def _norm(x, y):  # pragma: no cover (compiled)
    """``sqrt(x * x + y * y)``: the length of ``(x, y)``, within an ulp of ``math.hypot``'s
    (which guards against overflow these metre-scale numbers never reach, and which numba
    calls in libm, where this is inlined). With it :func:`chord_clearances` takes 1.8-2 times
    less time, with the same chords, obstacles and counts on every recorded call of the
    deployed check (docs/data/deploy/clearance_norm/)."""
    return math.sqrt(x * x + y * y)


@njit("float64(complex128, complex128)", cache=True)
def _along(r, d):  # pragma: no cover (compiled)
    """Where on a segment from its start, as a fraction of ``d`` (its end less its start), the
    point ``r`` from its start is nearest."""
    dd = d.real * d.real + d.imag * d.imag
    t = (r.real * d.real + r.imag * d.imag) / dd if dd > 0.0 else 0.0
    return min(max(t, 0.0), 1.0)


@njit("float64(complex128, complex128, complex128)", cache=True)
def segment_distance(p, a, b):  # pragma: no cover (compiled)
    """The distance from the point ``p`` to the segment ``a``-``b`` (complex ``x + iy``)."""
    d = b - a
    r = p - a
    t = _along(r, d)
    return _norm(r.real - t * d.real, r.imag - t * d.imag)


@vectorize(["float64(complex128, complex128, complex128)"], cache=True)
def point_segment_distance(p, a, b):  # pragma: no cover (compiled)
    """:func:`segment_distance`, broadcast over arrays."""
    return segment_distance(p, a, b)


@njit("float64(complex128, complex128, complex128, complex128)", cache=True)
def chord_segment_distance(p0, p1, a, b):  # pragma: no cover (compiled)
    """The smallest distance between the chord ``p0``-``p1`` and the segment ``a``-``b``:
    zero where they cross, else the least of the four end-to-segment distances."""
    d = min(segment_distance(p0, a, b), segment_distance(p1, a, b))
    d = min(d, segment_distance(a, p0, p1))
    d = min(d, segment_distance(b, p0, p1))
    u, w = p1 - p0, b - a
    ca = u.real * (a - p0).imag - u.imag * (a - p0).real
    cb = u.real * (b - p0).imag - u.imag * (b - p0).real
    c0 = w.real * (p0 - a).imag - w.imag * (p0 - a).real
    c1 = w.real * (p1 - a).imag - w.imag * (p1 - a).real
    return 0.0 if (ca * cb < 0.0 and c0 * c1 < 0.0) else d


@njit("complex128(complex128, complex128, complex128)", cache=True)
def closest_on_segment(p, a, b):  # pragma: no cover (compiled)
    """The point of the segment ``a``-``b`` nearest to ``p`` (complex ``x + iy``)."""
    return a + _along(p - a, b - a) * (b - a)


CHORD_BLOCK = 8
"""The chords :func:`chord_clearances` bounds together (two intervals at four sub-samples): a block whose
robot and disc stay far enough apart is not measured chord by chord."""


@njit(cache=True)
def _block_discs(x, cen, rad):  # pragma: no cover (compiled)
    """For each block of :data:`CHORD_BLOCK` chords of the points ``x`` (``(N + 1,)`` complex), a disc
    that holds the block's points (the chords between them too): its centre ``cen[k]``, the block's
    middle point, and radius ``rad[k]``."""
    N = x.shape[0] - 1
    for k in range(cen.shape[0]):
        c0, c1 = k * CHORD_BLOCK, min(N, (k + 1) * CHORD_BLOCK)
        mid = x[(c0 + c1) // 2]
        r2 = 0.0
        for c in range(c0, c1 + 1):
            u = x[c] - mid
            r2 = max(r2, u.real * u.real + u.imag * u.imag)
        cen[k], rad[k] = mid, math.sqrt(r2)


@njit("Tuple((float64[::1], float64, int64[::1], int64[::1], int64[::1], int64[::1], int64[::1], int64[::1], int64[::1]))("
      "complex128[:, ::1], complex128[:, ::1], float64[:, ::1], float64[::1], complex128[:, ::1], float64, float64, float64, int64, "
      "float64, int64, boolean, boolean)", cache=True)
def chord_clearances(p, q, touch, radii, walls, robot_radius, margin, not_worse, n_moving, drive_step,
                     commit, robust_drives, robust_ties):  # pragma: no cover (compiled)
    """For the roll-outs ``p`` (``(M, N + 1)`` complex, the first column now), the discs at
    ``q`` (``(n, N + 1)`` complex) touched at ``touch`` (``(n, N)``, inflated) and ``radii``
    (``(n,)``, not inflated), and the wall segments ``walls`` (``(nw, 2)`` complex ends,
    touched at ``robot_radius``): per sequence the smallest inflated clearance, the
    clearance now (one number: the same for all), the chord and the obstacle of the smallest
    (discs first, then walls; the first in that order on a tie), how many chords pass before
    the clearance first falls below ``min(margin, now - not_worse)`` (N when never), and how
    many before the discs not inflated, or a wall, are touched (inside one now, closed in on
    by more than ``not_worse``), and how many before a fixed obstacle is so touched. The fixed
    obstacles are the walls and the discs after the first ``n_moving`` (the static ones).
    Each obstacle's ``now`` is its own clearance now: being inside one person's margin (a track
    first seen close by, its disc inflated by a large uncertainty) licenses the robot neither
    into a wall nor towards another person (docs/nn-deploy.md). With one sequence that
    never falls below, all three are N. Last, per sequence, how many chords pass, among the
    first ``commit``, before the robot drives into what it touches: a chord on which it
    touches a disc not inflated, or a wall, as above, and moves towards it by more than
    ``drive_step`` (its displacement on that chord along the direction from the chord's end
    to the disc's centre there, or to the wall's nearest point); N when it does not within
    them. With ``robust_drives`` a mover's inflated disc counts for that last count as well
    (``touch``, with the threshold of the inflated clearance now, as the expected disc's is of
    the expected clearance now): moving towards a person inside the disc the margin is kept
    from drives into them; walls and static discs keep the test above. Last of all, with
    ``robust_ties``, the same count taken that robust way whatever ``robust_drives`` says (the
    tie-break of :attr:`~casadi_gpc.safety.check.SafetyCheck.uncertain_drives_in_s`); without it,
    a copy of the count before.

    Measured are only the chords that can change an answer: an obstacle, a block of
    :data:`CHORD_BLOCK` chords or a chord whose lower bound of its gap is above both the smallest
    gap found and the obstacle's thresholds (by 1e-9, rounding) is left out (a left-out chord's
    distance reads ``inf``, which no count takes), and the counts read only the obstacles a gap of
    which falls below a threshold: the same answers as every chord measured, whatever the order
    (tests/test_chord_skip.py holds them to that form, bit for bit)."""
    M, N = p.shape[0], p.shape[1] - 1
    n, nw = q.shape[0], walls.shape[0]
    cmin = np.empty(M)
    chord = np.zeros(M, np.int64)
    which = np.zeros(M, np.int64)
    kept = np.full(M, N, np.int64)
    contact = np.full(M, N, np.int64)
    fixed = np.full(M, N, np.int64)
    drives = np.full(M, N, np.int64)
    rdrives = np.full(M, N, np.int64)
    p0 = p[0, 0]
    # now: each obstacle's inflated clearance and distance to its expected disc (or the wall),
    # and the least inflated clearance (the clearance now this returns)
    now_j, now0_j = np.empty(n + nw), np.empty(n + nw)
    for j in range(n):
        r = p0 - q[j, 0]
        dj = _norm(r.real, r.imag)
        now_j[j], now0_j[j] = dj - touch[j, 0], dj - radii[j]
    for w in range(nw):
        dw = segment_distance(p0, walls[w, 0], walls[w, 1]) - robot_radius
        now_j[n + w], now0_j[n + w] = dw, dw
    now = math.inf
    for j in range(n + nw):
        now = min(now, now_j[j])
    # the thresholds: inside an obstacle's margin (or disc) now, not to close in on it further;
    # each obstacle's from its own clearance now (being inside one person's margin licenses the
    # robot neither into a wall nor towards anyone else)
    thr, thr0, thr1, thr2 = np.empty(n + nw), np.empty(n + nw), np.empty(n + nw), np.empty(n + nw)
    for j in range(n + nw):
        thr[j] = min(margin, now_j[j] - not_worse)
        thr0[j] = min(0.0, now0_j[j] - not_worse)
        # a mover's inflated disc, entered (or, inside it now, closed in on): robust_drives's
        # drive-in (thr1) and robust_ties's (thr2)
        thr2[j] = min(0.0, now_j[j] - not_worse) if j < n_moving else thr0[j]
        thr1[j] = thr2[j] if robust_drives else thr0[j]
    highest = thr.max() if n + nw else margin  # a gap at or above it loses the margin nowhere
    dist = np.empty((n + nw, N))
    # a lower bound of each obstacle's distance to any path that stays within D of now: its
    # sub-samples' least distance to where the robot is now, less its longest chord (a disc),
    # or the distance from now to the segment (a wall); less 1e-9 (rounding), less D
    near = np.empty(n + nw)
    loose = np.empty(n + nw)  # the least touching distance an obstacle's gaps are taken at
    for j in range(n):
        e2, l2, tmax = math.inf, 0.0, touch[j, 0]
        for c in range(N + 1):
            r = p0 - q[j, c]
            e2 = min(e2, r.real * r.real + r.imag * r.imag)
            if c < N:
                u = q[j, c + 1] - q[j, c]
                l2 = max(l2, u.real * u.real + u.imag * u.imag)
                tmax = max(tmax, touch[j, c])
        near[j] = math.sqrt(e2) - math.sqrt(l2) - 1e-9
        loose[j] = tmax
    for w in range(nw):
        near[n + w] = segment_distance(p0, walls[w, 0], walls[w, 1]) - 1e-9
        loose[n + w] = robot_radius
    floor = np.maximum(thr, thr0)  # a gap at or above both is below neither
    below = np.zeros(n + nw, np.bool_)  # whether a gap of the obstacle falls below one of its thresholds
    active = np.empty(n + nw, np.int64)
    robust = robust_ties or robust_drives
    nb = (N + CHORD_BLOCK - 1) // CHORD_BLOCK
    qcen, qrad, qtouch = np.empty((n, nb), np.complex128), np.empty((n, nb)), np.empty((n, nb))
    for j in range(n):
        _block_discs(q[j], qcen[j], qrad[j])
        for c in range(N):
            k = c // CHORD_BLOCK
            qtouch[j, k] = touch[j, c] if c % CHORD_BLOCK == 0 else max(qtouch[j, k], touch[j, c])
    pcen, prad = np.empty(nb, np.complex128), np.empty(nb)
    for m in range(M):
        reach2 = 0.0
        for c in range(1, N + 1):
            r = p[m, c] - p0
            reach2 = max(reach2, r.real * r.real + r.imag * r.imag)
        low = near - math.sqrt(reach2)
        low -= loose  # below which no gap of the obstacle falls (its inflated, and so its expected, disc)
        _block_discs(p[m], pcen, prad)
        best, bj, bc = math.inf, 0, 0
        # the nearest first, so that the far ones are left out once their bound is above the
        # smallest gap found and the thresholds; the first in (obstacle, chord) order on a tie
        for j in np.argsort(low):
            if low[j] > best and low[j] >= floor[j]:
                below[j] = False
                continue
            least, least0 = math.inf, math.inf  # its least gaps measured (NaN is never less)
            if j < n:
                fj, rj = floor[j], radii[j]
                for k in range(nb):
                    c0, c1 = k * CHORD_BLOCK, min(N, (k + 1) * CHORD_BLOCK)
                    # the block left out when its robot's and disc's discs are apart by more than the gap to beat
                    x = ((best if best > fj else fj) + 1e-9) + prad[k] + qrad[j, k] + qtouch[j, k]
                    u = pcen[k] - qcen[j, k]
                    if x < 0.0 or u.real * u.real + u.imag * u.imag > x * x:
                        dist[j, c0:c1] = math.inf
                        continue
                    rr = p[m, c0] - q[j, c0]
                    a2 = rr.real * rr.real + rr.imag * rr.imag
                    for c in range(c0, c1):
                        r1 = p[m, c + 1] - q[j, c + 1]
                        b2 = r1.real * r1.real + r1.imag * r1.imag
                        ur, ui = r1.real - rr.real, r1.imag - rr.imag
                        # and a chord, by min(|a|^2, |b|^2) - |u|^2 / 4 <= its squared distance (ends a, b; u = b - a)
                        tc = touch[j, c] + (best if best > fj else fj) + 1e-9
                        if tc >= 1e-3 and (a2 if a2 < b2 else b2) - 0.25 * (ur * ur + ui * ui) > tc * tc:
                            dist[j, c] = math.inf
                        else:
                            s = (rr.real * ur + rr.imag * ui) / ((ur * ur + ui * ui) + 1e-18)
                            s = min(max(-s, 0.0), 1.0)
                            d = _norm(rr.real + s * ur, rr.imag + s * ui)
                            dist[j, c] = d
                            g = d - touch[j, c]
                            if g < best or (g == best and (j < bj or (j == bj and c < bc))):
                                best, bj, bc = g, j, c
                            least = g if g < least else least
                            g = d - rj
                            least0 = g if g < least0 else least0
                        rr, a2 = r1, b2
            else:
                a, b = walls[j - n, 0], walls[j - n, 1]
                for c in range(N):
                    d = chord_segment_distance(p[m, c], p[m, c + 1], a, b)
                    dist[j, c] = d
                    g = d - robot_radius
                    if g < best or (g == best and (j < bj or (j == bj and c < bc))):
                        best, bj, bc = g, j, c
                    least = g if g < least else least
                least0 = least
            below[j] = least < thr[j] or least0 < thr0[j] or (robust and j < n_moving and least < thr2[j])
        cmin[m], which[m], chord[m] = best, bj, bc
        if M == 1 and best >= highest:
            continue  # never below: no need to find where (clear of the inflated discs: of the expected ones too)
        k_kept, k_contact, k_fixed, k_drives, k_rdrives = N, N, N, N, N
        if not robust_ties:
            k_rdrives = 0  # not wanted: the loop's end does not wait for it (the copy is made below)
        # the obstacles a gap of which falls below a threshold (the others keep the margin and keep off
        # their discs all along), and whether a fixed one is among them (its first touch is wanted too)
        na, any_fixed = 0, False
        for j in range(n + nw):
            if below[j]:
                active[na] = j
                na += 1
                any_fixed = any_fixed or j >= n_moving
        if na == 0:
            continue
        for c in range(N):
            for i in range(na):
                j = active[i]
                t = touch[j, c] if j < n else robot_radius
                r0 = radii[j] if j < n else robot_radius
                if k_kept == N and dist[j, c] - t < thr[j]:
                    k_kept = c
                inside = dist[j, c] - r0 < thr0[j]
                if inside:
                    if k_contact == N:
                        k_contact = c
                    if k_fixed == N and j >= n_moving:
                        k_fixed = c
                r_inside = inside  # (the robust count's: wanted only with robust_ties or robust_drives)
                if robust and not inside and j < n_moving:
                    r_inside = dist[j, c] - t < thr2[j]
                    if robust_drives:
                        inside = r_inside
                wanted = (inside and k_drives == N) or (r_inside and k_rdrives == N)
                if wanted and c < commit:
                    end = p[m, c + 1]
                    u = (q[j, c + 1] if j < n else closest_on_segment(end, walls[j - n, 0], walls[j - n, 1])) - end
                    du = _norm(u.real, u.imag)
                    v = end - p[m, c]
                    if du > 0.0 and (v.real * u.real + v.imag * u.imag) > drive_step * du:
                        if inside and k_drives == N:
                            k_drives = c
                        if r_inside and k_rdrives == N:
                            k_rdrives = c
            if k_kept < N and k_contact < N and (k_fixed < N or not any_fixed) and (
                    (k_drives < N and k_rdrives < N) or c + 1 >= commit):
                break
        kept[m], contact[m], fixed[m], drives[m] = k_kept, k_contact, k_fixed, k_drives
        if robust_ties:
            rdrives[m] = k_rdrives
    if not robust_ties:
        rdrives[:] = drives  # (for a sequence never below, both are N)
    return cmin, now, chord, which, kept, contact, fixed, drives, rdrives


@njit("float64[:, ::1](complex128[::1], complex128[:, ::1])", cache=True)
def path_segment_distances(p, walls):  # pragma: no cover (compiled)
    """``(nw, K)``: :func:`chord_segment_distance` of each chord of the path ``p``
    (``(K + 1,)`` complex) to each wall segment (``(nw, 2)`` complex ends)."""
    out = np.empty((walls.shape[0], p.shape[0] - 1))
    for w in range(walls.shape[0]):
        for c in range(p.shape[0] - 1):
            out[w, c] = chord_segment_distance(p[c], p[c + 1], walls[w, 0], walls[w, 1])
    return out


def _screen_signature(readonly: bool):
    """``screen_obstacles``' signature; the forecasts' arrays may be read-only (a batch's)."""
    f3, f2 = types.Array(types.float64, 3, "C", readonly=readonly), types.Array(types.float64, 2, "C", readonly=readonly)
    out = types.Tuple((types.complex128[:, ::1], types.float64[:, ::1]))
    return out(f3, f2, types.float64[::1], types.float64, types.float64[:, ::1], types.float64[::1])


@njit([_screen_signature(False), _screen_signature(True)], cache=True)
def screen_obstacles(means, worst, base, sigmas, static_xy, static_base):  # pragma: no cover (compiled)
    """The quick screen's obstacles: positions now and at steps 1..H, ``(n, H + 1)`` complex
    (now: the step back from step 1, ``2 q_1 - q_2``), and touching distances ``(n, H)``
    (``base`` = radius + the robot's, plus ``sigmas`` worst standard deviations
    ``worst``); the movers ``means`` (``(nm, H, 2)``) first, then the static discs
    (``static_xy`` ``(ns, 2)``, ``static_base`` ``(ns,)``)."""
    nm, H, ns = means.shape[0], means.shape[1], static_xy.shape[0]
    q = np.empty((nm + ns, H + 1), np.complex128)
    touch = np.empty((nm + ns, H))
    for j in range(nm):
        for k in range(H):
            q[j, k + 1] = complex(means[j, k, 0], means[j, k, 1])
            touch[j, k] = base[j] + sigmas * worst[j, k]
        if H > 1:
            q[j, 0] = complex(2.0 * q[j, 1].real - q[j, 2].real, 2.0 * q[j, 1].imag - q[j, 2].imag)
        else:
            q[j, 0] = q[j, 1]
    for i in range(ns):
        for k in range(H + 1):
            q[nm + i, k] = complex(static_xy[i, 0], static_xy[i, 1])
        for k in range(H):
            touch[nm + i, k] = static_base[i]
    return q, touch


@njit("Tuple((float64, int64, int64))(complex128, complex128[:, ::1], float64[:, ::1], float64[::1])", cache=True)
def reach_bound(p0, q, touch, reach):  # pragma: no cover (compiled)
    """The quick screen's reach bound (:meth:`~casadi_gpc.safety.screen.QuickScreen._quick`, 1.):
    its least value ``|p0 - q_k| - |q_k - q_(k-1)| - touch_k - reach_k`` over obstacles and
    steps, and where: the first (obstacle, step) in row order on a tie. (``math.hypot``, not
    :func:`_norm`: the plain-float loops of the screen take ``abs`` of a complex, and the two
    forms give the same numbers to the bit, ``tests/test_safety.py``; so does :func:`chord_bound`.)"""
    best, bj, bk = math.inf, 0, 0
    for j in range(q.shape[0]):
        for k in range(q.shape[1] - 1):
            a, b = p0 - q[j, k + 1], q[j, k + 1] - q[j, k]
            g = math.hypot(a.real, a.imag) - math.hypot(b.real, b.imag) - touch[j, k] - reach[k]
            if g < best or (j == 0 and k == 0):
                best, bj, bk = g, j, k
    return best, bj, bk


@njit("Tuple((float64, int64, int64))(complex128[::1], complex128[:, ::1], float64[:, ::1], float64[::1])", cache=True)
def chord_bound(pts, q, touch, sag):  # pragma: no cover (compiled)
    """The quick screen's chord bound (:meth:`~casadi_gpc.safety.screen.QuickScreen._quick`, 2.):
    the closest approach of the robot's chords between the sample instants ``pts`` to each
    obstacle, less its touching distance and the arc's ``sag``; the least and where."""
    best, bj, bk = math.inf, 0, 0
    for j in range(q.shape[0]):
        for k in range(pts.shape[0] - 1):
            r0, r1 = pts[k] - q[j, k], pts[k + 1] - q[j, k + 1]
            dr, di = r1.real - r0.real, r1.imag - r0.imag
            dd = dr * dr + di * di
            t = -(r0.real * dr + r0.imag * di) / dd if dd > 1e-18 else 0.0
            t = min(max(t, 0.0), 1.0)
            g = math.hypot(r0.real + t * dr, r0.imag + t * di) - touch[j, k] - sag[k]
            if g < best or (j == 0 and k == 0):
                best, bj, bk = g, j, k
    return best, bj, bk


@njit("Tuple((float64, int64, int64, int64))(float64, float64, float64, float64[:, :, ::1], float64, float64, float64, "
      "complex128[:, ::1], float64[:, ::1], complex128[:, ::1], float64)", cache=True)
def escape_bounds(x, y, h, wheels, T, W, sag_scale, q, touch, walls, robot_radius):  # pragma: no cover (compiled)
    """The quick screen's chord bound (:func:`chord_bound`) of each sequence of ``wheels``
    (``(M, H, 2)``) rolled out at the sample instants from the pose ``(x, y, h)`` with the
    robot model: the discs ``q``, ``touch`` as there, and the wall segments ``walls`` (the
    chords' distances to them less ``robot_radius``), each interval less its arc's sag
    (``|a + b| |a - b| sag_scale``). Returns the largest of the sequences' bounds (the first
    on a tie), which sequence, and the (obstacle, interval) of its least."""
    M, H = wheels.shape[0], wheels.shape[1]
    n, nw = q.shape[0], walls.shape[0]
    pts = np.empty(H + 1, np.complex128)
    sag = np.empty(H)
    best, bm, bj, bk = -math.inf, 0, 0, 0
    for m in range(M):
        px, py, ph = x, y, h
        pts[0] = complex(px, py)
        for k in range(H):
            a, b = wheels[m, k, 0], wheels[m, k, 1]
            sag[k] = abs(a + b) * abs(a - b) * sag_scale
            px, py, ph = _robot_step(px, py, ph, a, b, T, W)
            pts[k + 1] = complex(px, py)
        low, lj, lk = chord_bound(pts, q, touch, sag) if n else (math.inf, 0, 0)
        for w in range(nw):
            for k in range(H):
                g = chord_segment_distance(pts[k], pts[k + 1], walls[w, 0], walls[w, 1]) - robot_radius - sag[k]
                if g < low:
                    low, lj, lk = g, n + w, k
        if low > best:
            best, bm, bj, bk = low, m, lj, lk
    return best, bm, bj, bk


@njit("void(float64[:, :, ::1], int64, float64, float64, float64[:, ::1], float64[::1], boolean, float64, float64)",
      cache=True)
def approach(out, offset, v0r, v0l, targets, swerve, clip, vmax, dv):  # pragma: no cover (compiled)
    """Wheel-speed sequences that approach targets at the acceleration limit and hold them:
    ``out[m, offset + k] = v0 + min(max(t_m - v0, -dv (k + 1)), dv (k + 1))`` for the steps
    after ``offset``, ``v0`` the wheel speeds ``(v0r, v0l)`` held to ``+-vmax``; the targets
    ``t_m = targets[m] + swerve[m] * max(mean(v0), vmax / 4)`` (the swerves keep the current
    mean speed), held to ``+-vmax`` when ``clip``. The check's manoeuvres and searched grid
    (:meth:`~casadi_gpc.safety.check.TrajectoryCheck.manoeuvres`, ``_searched``), compiled: the
    numpy expression's numbers bit for bit (``tests/test_safety.py``)."""
    a = np.minimum(np.maximum(v0r, -vmax), vmax)
    b = np.minimum(np.maximum(v0l, -vmax), vmax)
    mean, quarter = 0.5 * (a + b), 0.25 * vmax
    add = quarter if quarter > mean else mean  # max(mean, quarter), as Python's max takes it
    for m in range(out.shape[0]):
        tr, tl = targets[m, 0] + swerve[m] * add, targets[m, 1] + swerve[m] * add
        if clip:
            tr, tl = np.minimum(np.maximum(tr, -vmax), vmax), np.minimum(np.maximum(tl, -vmax), vmax)
        for k in range(out.shape[1] - offset):
            reach = dv * (k + 1)
            out[m, offset + k, 0] = a + np.minimum(np.maximum(tr - a, -reach), reach)
            out[m, offset + k, 1] = b + np.minimum(np.maximum(tl - b, -reach), reach)
