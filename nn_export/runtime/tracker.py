"""The deployed path's situations: observations in, situations out, exactly as the planner
builds them (numpy only)."""
from __future__ import annotations

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.ekf import EKFSettings
from casadi_gpc.progress import ReferenceClock
from casadi_gpc.tracking import TrackBank
from casadi_gpc.types import Observation

from .situation import Situation, reference_poses, track_estimate

__all__ = ["SituationTracker"]


class SituationTracker:
    """Builds the :class:`Situation` from the stream of observations, exactly as the GPC
    does: the planner's bank of obstacle filters (:class:`~casadi_gpc.tracking.TrackBank`),
    stepped once per sample, and the preset's :class:`ReferenceClock`. ``update(observation)``
    once per sample.

    Used by the deployed policy and by on-policy (DAgger) labelling, so the network sees
    what the planner would see.
    """

    def __init__(self, config: PlannerConfig, ekf_settings: EKFSettings | None = None,
                 reference_steps: int | None = None):
        self.config = config
        self.ekf_settings = ekf_settings or EKFSettings()
        # desired poses computed per update (steps 0..reference_steps, at least H): the
        # two-pass policy needs 2H - 1, and one call is cheaper than two
        self.reference_steps = max(int(reference_steps or config.horizon), config.horizon)
        self.reference_ahead_: np.ndarray | None = None
        self.reset()

    def reset(self) -> None:
        self.reference_ahead_ = None
        self.bank = TrackBank(self.config.sample_time_s, self.ekf_settings)
        self.clock = ReferenceClock(self.config.sample_time_s, self.config.max_lead_m)

    @property
    def counters(self) -> dict:
        """The bank's counters (:data:`casadi_gpc.tracking.TRACK_COUNTERS`)."""
        return self.bank.counters

    def observe(self, obs: Observation) -> None:
        """Fuse one sample's measurements and advance the clock, without building the
        situation (for samples whose decision is not wanted)."""
        self.bank.step(obs.moving)
        self.clock.update(obs.reference, obs.t_s, (obs.robot.x_m, obs.robot.y_m))

    def update(self, obs: Observation) -> Situation:
        """Fuse one sample and return the situation at it (call once per sample).
        ``reference_ahead_`` then holds the desired poses at steps 0..``reference_steps``
        (the situation's are its first H + 1)."""
        H, T = self.config.horizon, self.config.sample_time_s
        seen = self.bank.step(obs.moving)
        tracks = tuple(track_estimate(ekf, m.obstacle_id, m.radius_m, H) for m, ekf in seen)
        self.clock.update(obs.reference, obs.t_s, (obs.robot.x_m, obs.robot.y_m))
        ref = self.reference_ahead_ = reference_poses(obs.reference, self.clock.s_m, T, self.reference_steps)
        return Situation(obs.robot, ref[:H + 1], T, obs.reference.speed_mps, tracks, tuple(obs.static))
