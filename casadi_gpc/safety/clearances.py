"""The exact check's measurements: wheel-speed sequences rolled out with the one robot model,
sub-sampled inside every interval, and their clearances to the obstacles' discs (closest
approach on every chord) and to the walls' segments (distance between chord and segment),
compiled (:mod:`casadi_gpc.safety.distances`; see :mod:`casadi_gpc.safety`). A part of :class:`~casadi_gpc.safety.check.TrajectoryCheck`."""
from __future__ import annotations

import numpy as np

from .distances import chord_clearances, point_segment_distance, rollouts

__all__ = ["Clearances", "NOT_WORSE_M", "DRIVEN_MPS"]
NOT_WORSE_M = 1e-6  # inside the margin, a candidate may lose this much clearance and pass

DRIVEN_MPS = 0.05
"""A robot that moves towards what it touches faster than this drives into it; slower, it is
run into (../shared/CONTRACT.md: the same speed marks a collision as the robot's own doing)."""


class Clearances:
    """:meth:`rollout`, :meth:`clearances` and :meth:`wall_bounds` for a
    :class:`~casadi_gpc.safety.check.TrajectoryCheck` (its horizon, sub-steps, robot,
    sub-sample times and commitment time)."""

    robust_drive_in = False
    """Whether moving towards a person inside their disc inflated by the forecast's
    uncertainty counts as driving into them too, not only inside their expected disc
    (:func:`~casadi_gpc.safety.distances.chord_clearances`' ``robust_drives``; set by
    :class:`~casadi_gpc.safety.filter.SafetyFilter`)."""

    robust_drive_ties = False
    """Whether options equal on the first two keys of the check's order are ranked next by how
    late each moves towards a person inside their disc inflated by the forecast's uncertainty
    (the ninth of :meth:`clearances`' answers; set by
    :class:`~casadi_gpc.safety.filter.SafetyFilter`)."""

    def rollout(self, state, wheels: np.ndarray) -> np.ndarray:
        """Robot positions at the sub-sample instants as complex numbers x + iy,
        ``(M, H * substeps + 1)``, the first column now. ``state`` = (x, y, heading, ...),
        ``wheels`` (M, H, 2) (:func:`~casadi_gpc.safety.distances.rollouts`, compiled)."""
        return rollouts(np.ascontiguousarray(state, dtype=float), np.ascontiguousarray(wheels, dtype=float), self._tau,
                        self.sample_time_s, self.robot.wheel_base_m)

    def clearances(self, state, wheels: np.ndarray, obstacles) -> tuple:
        """For each sequence in ``wheels`` (M, H, 2): the smallest inflated clearance over the
        horizon, the clearance now, the chord index and the obstacle of the minimum (the
        obstacles' index: discs first, then walls), and how many chords pass before the
        clearance first falls below the threshold (the margin, or, inside it, the clearance
        now): H * substeps when it never does; and how many pass before it touches the
        obstacles' discs not inflated by their uncertainty, or a wall (or, touching one now,
        closes in), H * substeps when it never does; and the same for the fixed obstacles
        alone, the walls and static discs; and how many pass, within the commitment time,
        before it drives into what it touches (moving towards it faster than
        :data:`DRIVEN_MPS` while touching it; H * substeps when it does not so soon); and the
        same with a person's disc inflated by the forecast's uncertainty counted as touching
        them (with :attr:`robust_drive_ties`; else the count before, again)
        (:func:`~casadi_gpc.safety.distances.chord_clearances`,
        compiled: every sequence against every obstacle, at less than the numpy form's cost
        against the few within reach)."""
        M, N = wheels.shape[0], self.horizon * self.substeps
        walls = obstacles.walls
        if not len(obstacles.q) + len(walls):
            inf = np.full(M, np.inf)
            return (inf, inf, np.zeros(M, int), np.zeros(M, int), np.full(M, N), np.full(M, N), np.full(M, N),
                    np.full(M, N), np.full(M, N))
        q, touch = obstacles.sub_samples()
        cmin, now, chord, which, kept, contact, fixed, drives, rdrives = chord_clearances(
            self.rollout(state, wheels), q, touch, obstacles.radii, walls, self.robot.radius_m, self.margin_m,
            NOT_WORSE_M, len(obstacles.moving), DRIVEN_MPS * self.sample_time_s / self.substeps, self._commit_chords,
            self.robust_drive_in, self.robust_drive_ties)
        return cmin, np.full(M, now), chord, which, kept, contact, fixed, drives, rdrives

    def wall_bounds(self, p0: complex, walls: np.ndarray, reach) -> np.ndarray:
        """``(nw, len(reach))``: the clearance to each wall that a robot within path length
        ``reach[k]`` of ``p0`` keeps at least (the walls stand still)."""
        d = point_segment_distance(p0, walls[:, 0], walls[:, 1]) - self.robot.radius_m
        return d[:, None] - np.asarray(reach)[None, :]
