"""The deployed path's situations: observations in, situations out, exactly as the planner
builds them (numpy only)."""
from __future__ import annotations

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.estimation.ekf import EKFSettings
from casadi_gpc.progress import ReferenceClock
from casadi_gpc.estimation.track_rows import RowBank
from casadi_gpc.types import Observation

from .situation import Situation, TrackEstimate, reference_rows, row_track_estimates

__all__ = ["SituationTracker"]


class SituationTracker:
    """Builds the :class:`Situation` from the stream of observations, exactly as the GPC
    does: the planner's obstacle filters, in the bank that holds their estimates as arrays
    (:class:`~casadi_gpc.estimation.track_rows.RowBank`: the planner's
    :class:`~casadi_gpc.estimation.tracking.TrackBank`'s numbers), stepped once per sample, and the
    preset's :class:`ReferenceClock`. ``update(observation)``
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
        self.reset()

    def reset(self) -> None:
        self._rows: list | None = None  # the desired poses of the last update, as rows
        self._ahead: np.ndarray | None = None  # ... as an array, once asked for
        self.bank = RowBank(self.config.sample_time_s, self.ekf_settings, horizon=self.config.horizon)
        self.clock = ReferenceClock(self.config.sample_time_s, self.config.max_lead_m)

    @property
    def counters(self) -> dict:
        """The bank's counters (:data:`casadi_gpc.estimation.tracking.TRACK_COUNTERS`)."""
        return self.bank.counters

    def observe(self, obs: Observation) -> None:
        """Fuse one sample's measurements and advance the clock, without building the
        situation (for samples whose decision is not wanted)."""
        self.bank.step(obs.moving, obs.t_s)
        self.clock.update(obs.reference, obs.t_s, (obs.robot.x_m, obs.robot.y_m))

    @property
    def reference_ahead_(self) -> np.ndarray | None:
        """The desired poses at steps 0..``reference_steps`` of the last update, shape
        (reference_steps + 1, 3) (the situation's are its first H + 1)."""
        if self._ahead is None and self._rows is not None:
            self._ahead = np.array(self._rows, dtype=float).reshape(len(self._rows), 3)
        return self._ahead

    def track(self, obs: Observation) -> tuple[tuple[TrackEstimate, ...], list[tuple]]:
        """:meth:`update` without building the :class:`Situation` (call one of them once per
        sample): the track estimates and the desired poses at steps 0..``reference_steps``
        as rows ``(x, y, heading)`` (the deployed policy's decision, where making the
        situation's arrays cost more than using them)."""
        cfg = self.config
        H = cfg.horizon
        bank = self.bank
        tracks = row_track_estimates(bank.step(obs.moving, obs.t_s), bank.sample_time_s, bank.settings, H)
        r, ref = obs.robot, obs.reference
        s_m = self.clock.update(ref, obs.t_s, (r.x_m, r.y_m))
        self._rows = rows = reference_rows(ref, s_m, cfg.sample_time_s, self.reference_steps)
        self._ahead = None
        return tracks, rows

    def track_within(self, obs: Observation, max_wheel_speed_mps: float, counters: dict) -> tuple:
        """``(obs, *track(obs))`` with the robot's wheel speeds held to ``max_wheel_speed_mps`` where it
        reports more (a glitching encoder), counted in ``counters`` as ``wheel_state_held``: the
        planner's rule (:meth:`~casadi_gpc.types.Observation.with_wheels_within`). Until 2026-12-02 the
        network, bare, read 5 m/s into its features and roll-out, far outside what it was trained on."""
        held = obs.with_wheels_within(max_wheel_speed_mps)
        if held is not None:
            obs = held
            counters["wheel_state_held"] = counters.get("wheel_state_held", 0) + 1
        return (obs, *self.track(obs))

    def update(self, obs: Observation) -> Situation:
        """Fuse one sample and return the situation at it (call once per sample).
        :attr:`reference_ahead_` then holds the desired poses at steps 0..``reference_steps``."""
        tracks, _ = self.track(obs)
        return Situation(obs.robot, self.reference_ahead_[:self.config.horizon + 1], self.config.sample_time_s,
                         obs.reference.speed_mps, tracks, tuple(obs.static), walls=tuple(obs.walls))
