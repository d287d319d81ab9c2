"""Every number the situation sampler (:mod:`nn_export.training.sampler`, whose module docstring
gives the distributions) draws with, as one frozen dataclass: part of a dataset's ``spec_id``."""
from __future__ import annotations

from dataclasses import dataclass, replace

from casadi_gpc.robot import RobotParams

__all__ = ["SamplerSettings"]


@dataclass(frozen=True)
class SamplerSettings:
    """The distributions of :func:`sample_situation` (see the module docstring). Every
    number the sampler draws with is a field here, so all of them are part of a dataset's
    ``spec_id``: a resumed dataset never appends situations drawn otherwise. Pairs are the
    bounds of a uniform draw; ``p_*`` are probabilities."""

    # --- the reference
    ref_speed_mps: tuple[float, float] = (0.15, 0.6)
    """The reference point's speed, m/s."""
    p_rollout_reference: float = 0.2
    """Share of situations whose desired trajectory is a robot rollout (the second pass)."""
    rollout_speed_mps: tuple[float, float] = (0.1, 0.6)
    """Rollout mode: the random wheel plan's target speed, m/s."""
    rollout_turn_rate_std_rad_s: float = 0.3
    """Rollout mode: std of its initial target turn rate, rad/s."""
    rollout_turn_rate_walk_rad_s: float = 0.15
    """Rollout mode: std of the change of the target turn rate per step, rad/s."""
    p_straight: float = 0.5
    """Share of path pieces that are straight (the others are arcs turning either way)."""
    arc_radius_m: tuple[float, float] = (2.0, 10.0)
    """Radius of an arc piece, m."""
    p_curvature_change: float = 0.5
    """Share of paths whose curvature changes ahead of the reference point."""
    curvature_change_horizons: tuple[float, float] = (0.0, 1.0)
    """Where it changes: this many horizons of reference travel ahead of the reference point."""
    path_ahead_horizons: float = 2.0
    """The path runs on this many horizons of reference travel beyond the reference point ..."""
    path_ahead_margin_m: float = 5.0
    """... plus this, m (unless it ends, below)."""
    p_path_end: float = 0.1
    """Share of paths that end near the reference point (the desired points bunch up)."""
    path_end_horizons: tuple[float, float] = (0.0, 1.2)
    """Where such a path ends, in horizons of reference travel ahead of the reference point."""
    extra_history_samples: int = 2
    """The reference point is at sample (longest obstacle history - 1) + U{0..this}."""
    # --- the robot, relative to the nominal reference point (tangent frame)
    p_tracking: float = 0.7
    """Share of robots close to the reference; the rest are recovering from a detour."""
    tracking_lag_m: tuple[float, float] = (-0.2, 0.6)
    """Tracking: lag behind the reference point along the path, m."""
    tracking_lateral_std_m: float = 0.15
    """Tracking: std of the lateral offset from the path, m."""
    tracking_heading_std_rad: float = 0.15
    """Tracking: std of the heading error, rad."""
    recovering_lag_m: tuple[float, float] = (-0.5, 1.5)
    """Recovering: lag along the path, m."""
    recovering_lateral_m: tuple[float, float] = (-1.2, 1.2)
    """Recovering: lateral offset, m."""
    recovering_heading_rad: tuple[float, float] = (-0.8, 0.8)
    """Recovering: heading error, rad."""
    p_at_rest: float = 0.05
    """Share of robots standing (both wheels at 0)."""
    speed_ratio: tuple[float, float] = (0.2, 1.3)
    """The others' forward speed, in reference speeds."""
    turn_rate_std_rad_s: float = 0.2
    """Std of their turn rate about the path's (speed x curvature), rad/s."""
    # --- moving obstacles
    moving_counts_paper: tuple[float, ...] = (0.15, 0.85)
    """Probabilities of 0, 1 moving obstacles (``paper`` layout)."""
    moving_counts_multi: tuple[float, ...] = (0.1, 0.4, 0.25, 0.25)
    """Probabilities of 0..3 moving obstacles (``multi`` layout)."""
    p_conflict: float = 0.65
    """Share of moving obstacles on a conflict course within the horizon."""
    conflict_first_step: float = 0.5
    """Earliest conflict, in samples from now (the latest: the end of the horizon)."""
    conflict_lateral_m: float = 0.4
    """A conflict passes within +-this of the desired point, laterally, m."""
    p_same_direction: float = 0.15
    """Share of conflicts from within +-``same_direction_deg`` of the path's tangent
    (overtaking or overtaken); the others come from the rest of the circle."""
    same_direction_deg: float = 30.0
    """Half-width of the same-direction cone, deg."""
    free_distance_m: tuple[float, float] = (0.6, 10.0)
    """Obstacles not on a conflict course: distance from the robot (any bearing, any heading), m."""
    obstacle_speed_mps: tuple[float, float] = (0.05, 0.6)
    """Speed of a moving obstacle that moves, m/s."""
    p_standing: float = 0.1
    """Share of moving obstacles standing still."""
    p_turning: float = 0.4
    """Share of moving obstacles turning."""
    turn_rate_rad_s: float = 0.25
    """Their turn rate: U(-this, this), rad/s."""
    obstacle_radius_m: tuple[float, float] = (0.2, 0.4)
    """Radius of a moving obstacle, m (the random suite's range)."""
    max_history: int = 8
    """Measured on the last U{``min_history``..this} samples ..."""
    min_history: int = 2
    """... (the lower bound) ..."""
    p_new_track: float = 0.05
    """... or on the last sample only (a new track, speed unknown), with this probability."""
    measurement_std_m: float = 0.02
    """Std of each measured coordinate, m (the scenario default)."""
    p_missing: float = 0.03
    """Probability that a measurement is missing."""
    # --- the paper's second pass (``first_pass`` given)
    moving_counts_second_pass: tuple[float, ...] = (0.0, 1.0)
    """Probabilities of 0, 1 moving obstacles."""
    second_pass_lateral_m: float = 1.6
    """A conflict passes within +-this of the desired point, laterally, m."""
    second_pass_max_clearance_m: float = 1.25
    """Kept only if it comes within this clearance of the desired path at some step 1..H, m."""
    second_pass_reference: str = "rollout"
    """The first pass's prediction: ``rollout`` (as the deployed policy) or ``plan`` (the GPC's open-loop plan)."""
    # --- static obstacles (``multi`` only)
    static_counts_multi: tuple[float, ...] = (0.4, 0.2, 0.2, 0.2)
    """Probabilities of 0..3 static obstacles."""
    p_static_beside_path: float = 0.6
    """Share of static obstacles beside the desired path ahead; the others anywhere around."""
    static_ahead_horizons: tuple[float, float] = (0.0, 1.0)
    """Beside the path: how far ahead along the desired trajectory, in horizons."""
    static_offset_m: float = 1.5
    """Beside the path: offset U(0, this) to either side, m."""
    static_distance_m: tuple[float, float] = (1.0, 8.0)
    """Anywhere: distance from the robot, m."""
    static_radius_m: tuple[float, float] = (0.15, 0.35)
    """Radius of a static obstacle, m."""
    # --- every obstacle
    min_clearance_m: float = 0.1
    """Obstacles closer than this to the robot's disc now are redrawn, m."""
    max_distance_m: float = 11.0
    """Obstacles farther than this from the robot are redrawn (inside the features' 12 m), m."""

    def for_robot(self, robot) -> "SamplerSettings":
        """These settings for ``robot``: the reference's and the roll-out's speeds the same
        fractions of its wheel limit as of the default robot's (0.15-0.6 m/s of 0.8 m/s: a slower
        robot is given references it can follow); everything else, the people's speeds included,
        as it is. The default robot's wheel limit gives these very settings (a dataset's
        ``spec_id`` unchanged)."""
        k = robot.max_wheel_speed_mps / RobotParams().max_wheel_speed_mps  # the robot they were drawn up for
        if k == 1.0:
            return self
        return replace(self, ref_speed_mps=tuple(v * k for v in self.ref_speed_mps),
                       rollout_speed_mps=tuple(v * k for v in self.rollout_speed_mps))
