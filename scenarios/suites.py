"""Every named suite behind one door: ``--suite NAME [--count N] [--seed S] [--movers N]
[--behaviour B]`` on the command line, ``suite=`` in the Gymnasium environment.

The random suites (``random``, ``random-multi``, ``encounters``: :mod:`scenarios.random_suite`)
ignore ``movers`` and ``behaviour``; the crowd suites (``circle-crossing``,
``square-crossing``: :mod:`scenarios.crowd_suite`) use them; ``ucy`` (the people of the UCY
recordings that ship with the package, :mod:`scenarios.pedestrian_cases`) ignores
``movers`` and takes ``behaviour`` ``replay`` (its default: the people replayed open loop),
``orca`` or ``social_force`` (walkers that follow their recording and give way to the
robot); the building suites (``corridor``, ``doorway``, ``corner``:
:mod:`scenarios.building_suite`) take ``movers`` and ``behaviour`` ``orca`` or
``social_force``."""
from __future__ import annotations

from dataclasses import dataclass

from functools import lru_cache

import numpy as np

from .building_suite import BUILDING_BEHAVIOURS, BUILDING_SUITES, building_scenario
from .crowd_suite import CROWD_BEHAVIOURS, CROWD_SUITES, crowd_scenario
from .model import TRACK_BEHAVIOURS, Scenario
from .random_suite import SUITES as RANDOM_SUITES
from .random_suite import random_scenario

__all__ = ["SUITES", "RANDOM_SUITES", "CROWD_SUITES", "BUILDING_SUITES", "RECORDED_SUITES", "CROWD_BEHAVIOURS", "SUITE_BEHAVIOURS",
           "Suite", "suite_scenario", "default_behaviour", "check_suite_options"]

RECORDED_SUITES = ("ucy",)
SUITES = RANDOM_SUITES + CROWD_SUITES + BUILDING_SUITES + RECORDED_SUITES
SUITE_BEHAVIOURS = tuple(dict.fromkeys(CROWD_BEHAVIOURS + TRACK_BEHAVIOURS))
"""Every ``behaviour`` a suite takes (the crowd suites: ``constant``, ``orca``,
``social_force``; ``ucy``: ``replay``, ``orca``, ``social_force``)."""


def default_behaviour(name: str) -> str:
    """The movers' behaviour of suite ``name`` unless told: ``replay`` for the recorded
    people, ``orca`` for the crowds."""
    return "replay" if name in RECORDED_SUITES else "orca"


def check_suite_options(name: str, movers, behaviour) -> None:
    """Refuse (``ValueError``) ``movers`` / ``behaviour`` given for a suite that does not take
    them (they were taken and ignored: random with 3 movers ran one): the crowd and building
    suites take both, the recorded people ``behaviour``. None: not given."""
    if movers is not None and name not in CROWD_SUITES + BUILDING_SUITES:
        raise ValueError(f"movers: suite {name} has its own movers (the crowd and building suites take movers)")
    if behaviour is not None and name not in CROWD_SUITES + BUILDING_SUITES + RECORDED_SUITES:
        raise ValueError(f"behaviour: suite {name} has its own movers (the crowd, building and recorded suites "
                         f"take behaviour)")


@dataclass(frozen=True)
class Suite:
    """A seeded suite of scenarios: which, how many, from which seed, and (crowd suites) how
    many movers of which behaviour."""

    name: str
    count: int = 100
    seed: int = 0
    movers: int = 5
    behaviour: str | None = None
    """None: :func:`default_behaviour` of the suite."""

    def __post_init__(self):
        if self.name not in SUITES:
            raise ValueError(f"unknown suite {self.name!r} (choose from {', '.join(SUITES)})")
        if self.count < 1:
            raise ValueError(f"count must be at least 1, got {self.count}")
        if self.seed < 0:
            raise ValueError(f"seed must not be negative, got {self.seed}")
        if self.movers < 0:
            raise ValueError(f"movers must not be negative, got {self.movers}")
        if self.behaviour is None:
            object.__setattr__(self, "behaviour", default_behaviour(self.name))
        allowed = (TRACK_BEHAVIOURS if self.name in RECORDED_SUITES else
                   BUILDING_BEHAVIOURS if self.name in BUILDING_SUITES else CROWD_BEHAVIOURS)
        if self.behaviour not in allowed:
            raise ValueError(f"suite {self.name}: unknown behaviour {self.behaviour!r} "
                             f"(choose from {', '.join(allowed)})")

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
        if self.is_crowd or self.name in BUILDING_SUITES:
            d.update(movers=self.movers, behaviour=self.behaviour)
        elif self.name in RECORDED_SUITES:
            d.update(behaviour=self.behaviour, cases=len(_recorded_cases()))
        return d


@lru_cache(maxsize=1)
def _recorded_cases():
    """Every case of the protocol in the shipped recordings, with its recording."""
    from .pedestrian_cases import cases
    from .recordings import SHIPPED, shipped_recording
    out = []
    for name in SHIPPED:
        rec = shipped_recording(name)
        out.extend((rec, c) for c in cases(rec))
    return tuple(out)


def _recorded_scenario(index: int, seed: int, behaviour: str) -> Scenario:
    """The ``index``-th case of a seeded order of every case (each case once per pass; a
    later pass draws other measurement noise)."""
    from .pedestrian_cases import case_scenario
    pool = _recorded_cases()
    order = np.random.default_rng([seed, 31]).permutation(len(pool))
    rec, case = pool[order[index % len(pool)]]
    sc = case_scenario(rec, case, behaviour, seed=int(np.random.default_rng([seed, index]).integers(2 ** 31)))
    from dataclasses import replace
    return replace(sc, name=f"{sc.name}-{index:04d}") if index >= len(pool) else sc


def suite_scenario(suite: Suite, index: int) -> Scenario:
    if suite.is_crowd:
        return crowd_scenario(suite.name, index, suite.seed, suite.movers, suite.behaviour)
    if suite.name in RECORDED_SUITES:
        return _recorded_scenario(index, suite.seed, suite.behaviour)
    if suite.name in BUILDING_SUITES:
        return building_scenario(suite.name, index, suite.seed, suite.movers, suite.behaviour)
    return random_scenario(suite.name, index, suite.seed)
