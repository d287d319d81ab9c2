"""Every named suite behind one door: ``--suite NAME [--count N] [--seed S] [--movers N]
[--behaviour B]`` on the command line, ``suite=`` in the Gymnasium environment.

The random suites (``random``, ``random-multi``, ``encounters``: :mod:`scenarios.random_suite`)
ignore ``movers`` and ``behaviour``; the crowd suites (``circle-crossing``,
``square-crossing``: :mod:`scenarios.crowd_suite`) use them."""
from __future__ import annotations

from dataclasses import dataclass

from .crowd_suite import CROWD_BEHAVIOURS, CROWD_SUITES, crowd_scenario
from .model import Scenario
from .random_suite import SUITES as RANDOM_SUITES
from .random_suite import random_scenario

__all__ = ["SUITES", "RANDOM_SUITES", "CROWD_SUITES", "CROWD_BEHAVIOURS", "Suite", "suite_scenario"]

SUITES = RANDOM_SUITES + CROWD_SUITES


@dataclass(frozen=True)
class Suite:
    """A seeded suite of scenarios: which, how many, from which seed, and (crowd suites) how
    many movers of which behaviour."""

    name: str
    count: int = 100
    seed: int = 0
    movers: int = 5
    behaviour: str = "orca"

    def __post_init__(self):
        if self.name not in SUITES:
            raise ValueError(f"unknown suite {self.name!r} (choose from {', '.join(SUITES)})")
        if self.count < 1:
            raise ValueError(f"count must be at least 1, got {self.count}")
        if self.seed < 0:
            raise ValueError(f"seed must not be negative, got {self.seed}")
        if self.movers < 0:
            raise ValueError(f"movers must not be negative, got {self.movers}")
        if self.behaviour not in CROWD_BEHAVIOURS:
            raise ValueError(f"unknown behaviour {self.behaviour!r} (choose from {', '.join(CROWD_BEHAVIOURS)})")

    @property
    def is_crowd(self) -> bool:
        return self.name in CROWD_SUITES

    def scenario(self, index: int) -> Scenario:
        """The ``index``-th scenario (independent of ``count``)."""
        return suite_scenario(self, index)

    def scenarios(self) -> list[Scenario]:
        return [self.scenario(i) for i in range(self.count)]

    def describe(self) -> dict:
        """What an EVAL document records of the suite."""
        d = {"suite": self.name, "count": self.count, "seed": self.seed}
        if self.is_crowd:
            d.update(movers=self.movers, behaviour=self.behaviour)
        return d


def suite_scenario(suite: Suite, index: int) -> Scenario:
    if suite.is_crowd:
        return crowd_scenario(suite.name, index, suite.seed, suite.movers, suite.behaviour)
    return random_scenario(suite.name, index, suite.seed)
