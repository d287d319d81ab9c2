"""The check's compiled clearances leave out what cannot change an answer
(:func:`casadi_gpc.safety.distances.chord_clearances`: obstacles, blocks of chords and chords whose
lower bound of the gap is above the smallest found and the thresholds; the counts over the
obstacles whose gaps fall below one): held here, bit for bit, to the kernel as it was before
(2026-12-01), which measured every chord of every obstacle its bound kept, on random crowds and
on every call of the deployed decision closed loop among 10 walkers (docs/nn-deploy.md, "The
failing decisions' search: fewer chords measured")."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from casadi_gpc.robot import RobotParams
from casadi_gpc.safety import SafetyFilter
from casadi_gpc.safety import clearances as clearances_module
from casadi_gpc.safety.clearances import DRIVEN_MPS, NOT_WORSE_M
from casadi_gpc.safety.distances import (_norm, chord_clearances, chord_segment_distance, closest_on_segment,
                                         segment_distance)
from casadi_gpc.types import ObstacleForecast, StaticObstacle

ROBOT = RobotParams()


@njit(chord_clearances.signatures[0], cache=True)
def _reference(p, q, touch, radii, walls, robot_radius, margin, not_worse, n_moving, drive_step,
               commit, robust_drives, robust_ties):
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
    computed = np.zeros(n + nw, np.bool_)
    for m in range(M):
        reach2 = 0.0
        for c in range(1, N + 1):
            r = p[m, c] - p0
            reach2 = max(reach2, r.real * r.real + r.imag * r.imag)
        low = near - math.sqrt(reach2)
        low -= loose  # below which no gap of the obstacle falls (its inflated, and so its expected, disc)
        best, bj, bc = math.inf, 0, 0
        # the nearest first, so that the far ones are left out once their bound is above the
        # smallest gap found and the thresholds; the first in (obstacle, chord) order on a tie
        for j in np.argsort(low):
            if low[j] > best and low[j] >= floor[j]:
                computed[j] = False
                continue
            computed[j] = True
            if j < n:
                rr = p[m, 0] - q[j, 0]
                for c in range(N):
                    r1 = p[m, c + 1] - q[j, c + 1]
                    ur, ui = r1.real - rr.real, r1.imag - rr.imag
                    s = (rr.real * ur + rr.imag * ui) / ((ur * ur + ui * ui) + 1e-18)
                    s = min(max(-s, 0.0), 1.0)
                    d = _norm(rr.real + s * ur, rr.imag + s * ui)
                    dist[j, c] = d
                    g = d - touch[j, c]
                    if g < best or (g == best and (j < bj or (j == bj and c < bc))):
                        best, bj, bc = g, j, c
                    rr = r1
            else:
                a, b = walls[j - n, 0], walls[j - n, 1]
                for c in range(N):
                    d = chord_segment_distance(p[m, c], p[m, c + 1], a, b)
                    dist[j, c] = d
                    g = d - robot_radius
                    if g < best or (g == best and (j < bj or (j == bj and c < bc))):
                        best, bj, bc = g, j, c
        cmin[m], which[m], chord[m] = best, bj, bc
        if M == 1 and best >= highest:
            continue  # never below: no need to find where (clear of the inflated discs: of the expected ones too)
        k_kept, k_contact, k_fixed, k_drives, k_rdrives = N, N, N, N, N
        if not robust_ties:
            k_rdrives = 0  # not wanted: the loop's end does not wait for it (the copy is made below)
        any_fixed = False  # a fixed obstacle near enough to be touched: its first touch is wanted too
        for j in range(n_moving, n + nw):
            any_fixed = any_fixed or computed[j]
        for c in range(N):
            for j in range(n + nw):
                if not computed[j]:
                    continue  # its gaps keep the margin and keep off its disc all along
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
                if (robust_ties or robust_drives) and not inside and j < n_moving:
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


def _same(a, b) -> bool:
    """The nine answers equal to the bit (the floats by their bits)."""
    (c1, n1, *i1), (c2, n2, *i2) = a, b
    return (np.array_equal(c1.view(np.int64), c2.view(np.int64)) and float(n1).hex() == float(n2).hex()
            and all(np.array_equal(x, y) for x, y in zip(i1, i2)))


def _arguments(f, state, W, obs) -> tuple:
    """``chord_clearances``' arguments as :meth:`~casadi_gpc.safety.clearances.Clearances.clearances` makes them."""
    q, touch = obs.sub_samples()
    return (f.rollout(state, W), q, touch, obs.radii, obs.walls, f.robot.radius_m, f.margin_m, NOT_WORSE_M,
            len(obs.moving), DRIVEN_MPS * f.sample_time_s / f.substeps, f._commit_chords, f.robust_drive_in,
            f.robust_drive_ties)


def _crowd(rng, i: int):
    """A random check: its settings, 0 to 15 movers (some standing, some twins of another: ties), up to 3
    static discs and 2 walls (some touching the robot now), and the grid, the manoeuvres and random
    sequences from a random state (sometimes one or two sequences)."""
    T, H = (0.5, 12) if i % 3 else (0.25, 8)
    f = SafetyFilter(ROBOT, T, H, margin_m=float(rng.choice([0.0, 0.05, 0.3])), sigmas=float(rng.choice([0.0, 2.0])),
                     substeps=int(rng.choice([2, 4, 5])), search=True, robust_drive_in=bool(i % 2),
                     robust_drive_ties=bool(i // 2 % 2))
    spread, speed = float(rng.choice([1.0, 3.0, 8.0])), float(rng.choice([0.0, 0.5, 1.5]))
    movers = []
    for k in range(int(rng.integers(0, 16))):
        if movers and rng.random() < 0.15:  # a twin: the same forecast under another id
            twin = movers[int(rng.integers(len(movers)))]
            movers.append(ObstacleForecast(k, twin.radius_m, twin.means_m.copy(), twin.covs_m2.copy()))
            continue
        start, v = rng.uniform(-spread, spread, 2), rng.uniform(-speed, speed, 2) * (rng.random() > 0.2)
        steps = np.arange(1, H + 1)[:, None]
        means = start + steps * T * v + np.cumsum(rng.normal(0.0, 0.05 * speed, (H, 2)), axis=0)
        sd = np.sqrt(np.cumsum(rng.uniform(1e-6, 0.05, (H, 2)), axis=0))
        covs = np.zeros((H, 2, 2))
        covs[:, 0, 0], covs[:, 1, 1] = sd[:, 0] ** 2, sd[:, 1] ** 2
        movers.append(ObstacleForecast(k, float(rng.uniform(0.1, 0.4)), means, covs))
    statics = tuple(StaticObstacle(tuple(rng.uniform(-3, 3, 2)), float(rng.uniform(0.1, 0.5)))
                    for _ in range(int(rng.integers(0, 4))))
    walls = None
    if rng.random() < 0.3:
        ends = rng.uniform(-4, 4, (int(rng.integers(1, 3)), 2, 2))
        walls = np.ascontiguousarray(ends[..., 0] + 1j * ends[..., 1])
    state = np.array([0.0, 0.0, rng.uniform(-math.pi, math.pi), *rng.uniform(-0.5, 1.0, 2)])
    vmax = ROBOT.max_wheel_speed_mps
    W = np.concatenate([f._searched(state[3:], H), f.manoeuvres(state[3:])[1],
                        rng.uniform(-vmax, vmax, (int(rng.integers(0, 6)), H, 2))])
    W = np.concatenate([W, W[:3]])  # twin sequences too
    if i % 7 == 0:
        W = W[int(rng.integers(len(W))):][:int(rng.integers(1, 3))]
    return f, state, f.obstacle_tracks(movers, statics, walls), np.ascontiguousarray(W)


def test_the_clearances_are_those_of_every_chord_measured_on_random_crowds():
    """Bit for bit the kernel as it was, over 600 random checks (movers near and far, standing, twins,
    statics and walls touching the robot now, every robust setting, one sequence or many); the
    answers the counts give are compared where they fall inside the horizon."""
    rng = np.random.default_rng(20261201)
    cases = lost = touched = fixed = driven = 0
    for i in range(600):
        f, state, obs, W = _crowd(rng, i)
        if not len(obs.q) + len(obs.walls):
            continue
        args = _arguments(f, state, W, obs)
        got, ref = chord_clearances(*args), _reference(*args)
        assert _same(got, ref), i
        N = args[0].shape[1] - 1
        cases += 1
        lost += int((got[4] < N).sum())
        touched += int((got[5] < N).sum())
        fixed += int((got[6] < N).sum())
        driven += int((got[7] < N).sum())
    assert cases > 500 and lost > 1000 and touched > 500 and fixed > 100 and driven > 100


def test_every_call_of_the_deployed_decision_closed_loop_is_the_reference_s(monkeypatch):
    """The deployed decision (``--controller nn``: the network behind the planner-free check) on the bench's
    crowd scene (circle-crossing, 10 ORCA walkers, seed 1, its first episode, whose commands fail the quick
    screen five times: the roll-out, the searched way out and its two phases): every call of the kernel
    gives the reference's answers to the bit, so every decision is the same."""
    from casadi_gpc.config import preset
    from gpcnav.controllers import ControllerSpec, make
    from scenarios import Suite
    from scenarios.simulator import simulate
    same = []

    def both(*args):
        got = chord_clearances(*args)
        same.append(_same(got, _reference(*args)))
        return got

    monkeypatch.setattr(clearances_module, "chord_clearances", both)
    sc = Suite("circle-crossing", 200, 1, 10, "orca").scenario(0)
    policy = make(ControllerSpec("nn"), preset("improved"), sc.robot)
    simulate(sc, policy, "nn")
    assert policy.counters["shield_rollouts"] >= 3 and len(same) > 20 and all(same)
