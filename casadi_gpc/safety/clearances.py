"""The exact check's measurements: wheel-speed sequences rolled out with the one robot model,
sub-sampled inside every interval, and their clearances to the obstacles' discs (closest
approach on every chord) and to the walls' segments (distance between chord and segment),
with the obstacles out of every sequence's reach left out (numpy only; see
:mod:`casadi_gpc.safety`). A part of :class:`~casadi_gpc.safety.check.TrajectoryCheck`."""
from __future__ import annotations

import numpy as np

from ..robot import robot_step
from .walls import chord_segment_distance, point_segment_distance

__all__ = ["Clearances", "FAR_M", "NOT_WORSE_M"]

FAR_M = 1e-3
"""An obstacle is left out of a roll-out (:meth:`Clearances.clearances`' ``within_reach``)
only when its bound keeps this much more than the margin (well above any rounding, and above
the clearance-now tolerance, so that what is below the threshold is the same)."""
NOT_WORSE_M = 1e-6  # inside the margin, a candidate may lose this much clearance and pass


class Clearances:
    """:meth:`rollout`, :meth:`clearances` and :meth:`_within_reach` for a
    :class:`~casadi_gpc.safety.check.TrajectoryCheck` (its horizon, sub-steps, robot and
    sub-sample times)."""

    # Written for speed: every step of the filter is a handful of whole-array operations
    # (numpy's per-call overhead, not the arithmetic, is what costs at these sizes).
    def rollout(self, state, wheels: np.ndarray) -> np.ndarray:
        """Robot positions at the sub-sample instants as complex numbers x + iy,
        ``(M, H * substeps + 1)``, the first column now. ``state`` = (x, y, heading, ...),
        ``wheels`` (M, H, 2)."""
        T, W = self.sample_time_s, self.robot.wheel_base_m
        vr, vl = wheels[..., 0], wheels[..., 1]
        # heading at the start of each interval: the model turns by (vr - vl) T / W per interval
        turn = (vr - vl) * (T / W)
        h0 = (state[2] - turn) + np.add.accumulate(turn, axis=-1)
        # one call of the model for every sub-sample of every interval, from a local origin
        dx, dy, _ = robot_step(np, 0.0, 0.0, h0[..., None], vr[..., None], vl[..., None], self._tau, W)
        d = dx + 1j * dy                                                      # (M, H, S)
        # interval start points: the cumulated full-interval displacements (last sub-sample)
        end = d[..., -1]
        start = (complex(state[0], state[1]) - end) + np.add.accumulate(end, axis=-1)
        M, N = wheels.shape[0], self.horizon * self.substeps
        p = np.empty((M, N + 1), dtype=complex)
        p[:, 0] = complex(state[0], state[1])
        p[:, 1:] = (start[..., None] + d).reshape(M, N)
        return p

    def clearances(self, state, wheels: np.ndarray, obstacles, within_reach: bool = False) -> tuple:
        """For each sequence in ``wheels`` (M, H, 2): the smallest inflated clearance over the
        horizon, the clearance now, the chord index and the obstacle of the minimum (the
        obstacles' index: discs first, then walls), and how many chords pass before the
        clearance first falls below the threshold (the margin, or, inside it, the clearance
        now): H * substeps when it never does; and how many pass before it touches the
        obstacles' discs not inflated by their uncertainty, or a wall (or, touching one now,
        closes in), H * substeps when it never does.

        ``within_reach``: the sequences are rolled out against the obstacles that one of them
        can come near (:meth:`_within_reach`) only; the others keep more than the margin all
        along, so the clearance now and how long each keeps the margin are the same, and so is
        the smallest clearance unless a left-out obstacle's bound is below it, where all are
        rolled out after all: the same numbers, at a fraction of the roll-outs in a crowd."""
        M, N = wheels.shape[0], self.horizon * self.substeps
        n, nw = len(obstacles.q), len(obstacles.walls)
        if not n + nw:
            inf = np.full(M, np.inf)
            return inf, inf, np.zeros(M, int), np.zeros(M, int), np.full(M, N), np.full(M, N)
        p0 = complex(state[0], state[1])
        q, touch = obstacles.sub_samples()
        walls, radii = obstacles.walls, obstacles.radii
        near = self._within_reach(state, wheels, obstacles) if within_reach else None
        if near is not None:
            idx, floor = near
            if not len(idx):
                return self.clearances(state, wheels, obstacles)
            now = np.full(M, self._now(p0, q, touch, walls))
            ip, iw = idx[idx < n], idx[idx >= n] - n
            q, touch, walls = q[ip], touch[ip], walls[iw]
            radii = np.concatenate([radii[ip], np.full(len(iw), self.robot.radius_m)]) if nw else radii[ip]
        elif nw:
            radii = np.concatenate([radii, np.full(nw, self.robot.radius_m)])
        p = self.rollout(state, wheels)
        rel = p[:, None, :] - q                                             # (M, n, N+1) robot - obstacle
        r0 = rel[..., :-1]                                                  # chord starts
        u = rel[..., 1:] - r0                                               # chord directions
        # closest approach on each chord: the relative motion is linear between sub-samples;
        # Re(r0 conj(u)) is the dot product, |u|^2 = Re(u conj(u))
        cu = np.conj(u)
        s = (r0 * cu).real / ((u * cu).real + 1e-18)
        s = np.minimum(np.maximum(-s, 0.0), 1.0)
        dist = np.abs(r0 + s * u)
        gap = dist - touch
        if len(walls):  # the walls stand still: the distance between each chord and each segment
            wdist = chord_segment_distance(p, walls[:, 0], walls[:, 1])    # (M, nw, N)
            dist = np.concatenate([dist, wdist], axis=1)
            gap = np.concatenate([gap, wdist - self.robot.radius_m], axis=1)
        flat = gap.reshape(M, -1)
        k = flat.argmin(axis=1)
        cmin = flat[np.arange(M), k]
        if near is None:
            now = np.full(M, self._now(p0, q, touch, walls)) if nw else (np.abs(rel[..., 0]) - touch[:, 0]).min(axis=1)
        threshold = np.minimum(self.margin_m, now - NOT_WORSE_M)
        if M == 1 and cmin[0] >= threshold[0]:
            kept = np.full(1, N)  # never below: no need to find where
            contact = kept  # clear of the inflated discs: of the expected ones too
        else:
            below = gap.min(axis=1) < threshold[:, None]
            kept = np.where(below.any(axis=1), below.argmax(axis=1), N)
            # how long before touching the discs where the forecasts expect the obstacles (not
            # inflated; inside one, before closing in), or a wall; those out of reach are never touched
            now0 = (self._distance_now(p0, rel, walls) - radii).min(axis=1)
            below0 = (dist - radii[:, None]).min(axis=1) < np.minimum(0.0, now0 - NOT_WORSE_M)[:, None]
            contact = np.where(below0.any(axis=1), below0.argmax(axis=1), N)
        if near is not None:
            if (floor < cmin).any():  # a left-out obstacle might hold a smallest clearance: all of them
                return self.clearances(state, wheels, obstacles)
            return cmin, now, k % N, idx[k // N], kept, contact
        return cmin, now, k % N, k // N, kept, contact

    def _distance_now(self, p0: complex, rel: np.ndarray, walls: np.ndarray) -> np.ndarray:
        """``(M, n + nw)``: the distance now to each disc's centre (from the roll-outs' first
        column) and to each wall segment."""
        d = np.abs(rel[..., 0])
        if not len(walls):
            return d
        w = point_segment_distance(p0, walls[:, 0], walls[:, 1])
        return np.concatenate([d, np.broadcast_to(w, (len(d), len(w)))], axis=1)

    def _now(self, p0: complex, q: np.ndarray, touch: np.ndarray, walls: np.ndarray) -> float:
        """The inflated clearance now to the discs (positions ``q``, touching distances
        ``touch``) and the wall segments ``walls``."""
        now = (np.abs(p0 - q[:, 0]) - touch[:, 0]).min() if len(q) else np.inf
        if len(walls):
            now = min(now, (point_segment_distance(p0, walls[:, 0], walls[:, 1]) - self.robot.radius_m).min())
        return now

    def wall_bounds(self, p0: complex, walls: np.ndarray, reach) -> np.ndarray:
        """``(nw, len(reach))``: the clearance to each wall that a robot within path length
        ``reach[k]`` of ``p0`` keeps at least (the walls stand still)."""
        d = point_segment_distance(p0, walls[:, 0], walls[:, 1]) - self.robot.radius_m
        return d[:, None] - np.asarray(reach)[None, :]

    def _within_reach(self, state, wheels: np.ndarray, obstacles):
        """The obstacles that some sequence of ``wheels`` (M, H, 2) can come near: those
        whose bound (as :meth:`bound`, with the longest path any of the sequences drives over
        each interval) is below the margin (and a little more: see :data:`FAR_M`). Returns
        ``(indices of those, the others' least bound)`` (discs first, then walls), or None
        when every obstacle is near."""
        q, walls = obstacles.q, obstacles.walls
        if len(q) + len(walls) < 2:
            return None
        reach = np.add.accumulate(np.abs(wheels[..., 0] + wheels[..., 1]).max(axis=0)) * (0.5 * self.sample_time_s)
        p0 = complex(state[0], state[1])
        low = (np.abs(q[:, 1:] - p0) - np.abs(q[:, 1:] - q[:, :-1])) - obstacles.touch - reach
        if len(walls):
            low = np.concatenate([low, self.wall_bounds(p0, walls, reach)])
        per = low.min(axis=1)
        near = per < self.margin_m + FAR_M
        if near.all():
            return None
        return np.flatnonzero(near), float(per[~near].min())
