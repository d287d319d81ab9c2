"""The planner kept on standby behind the safety filter (numpy only)."""
from __future__ import annotations

from ..types import ControlDecision, Observation

__all__ = ["StandbyPlanner"]


class StandbyPlanner:
    """A planner kept on standby: it is told every observation but solves only when asked.

    ``observe(observation)`` stores the observation; ``decide(observation)`` first replays
    the stored ones through the planner's estimation and reference clock (its
    ``estimate`` and ``desired_poses``, or its ``decide`` when it has neither) so that its
    obstacle filters and clock are exactly where they would have been, then decides. So
    the GPC behind a network costs nothing while the network is trusted. At most
    ``max_lag`` observations wait: beyond that the oldest is replayed at once, which bounds
    the catch-up time of a long run.
    """

    def __init__(self, planner, max_lag: int = 400):
        if not callable(getattr(planner, "decide", None)):
            raise TypeError("planner must have a decide(observation) method")
        self.planner = planner
        self.max_lag = int(max_lag)
        self.sample_time_s = getattr(planner, "sample_time_s", None)
        self._pending: list[Observation] = []
        self.replayed = 0

    @property
    def counters(self) -> dict:
        return getattr(self.planner, "counters", {})

    def reset(self) -> None:
        if hasattr(self.planner, "reset"):
            self.planner.reset()
        self._pending = []
        self.replayed = 0

    def _replay(self, obs: Observation) -> None:
        p = self.planner
        if hasattr(p, "estimate") and hasattr(p, "desired_poses"):
            p.estimate(obs)
            p.desired_poses(obs)
        else:
            p.decide(obs)
        self.replayed += 1

    def observe(self, observation: Observation) -> None:
        self._pending.append(observation)
        while len(self._pending) > self.max_lag:
            self._replay(self._pending.pop(0))

    def decide(self, observation: Observation) -> ControlDecision:
        for obs in self._pending:
            self._replay(obs)
        self._pending = []
        return self.planner.decide(observation)
