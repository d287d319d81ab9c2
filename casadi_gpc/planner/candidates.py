"""Persistent candidates: the planner's solutions kept alive from tick to tick.

Near an obstacle the GPC's cost has several minima (pass left, pass right, wait), so one
warm start can miss the cheapest. Solving from every fixed guess at every tick finds it, at
five to seven cold solves a tick. Instead, as TEB keeps one trajectory per homotopy class,
the planner keeps every distinct solution it found (one per class, named after the start it
came from), shifts each by one step and warm-starts it from itself at the next tick: a warm
start from last tick's optimum needs a few iterations. The fixed guesses are solved again
(with the incumbent's warm start, exactly the full multi-start of
:meth:`casadi_gpc.planner.gpc.GPCController.plan`) only when

- there is no candidate (the first tick, or all were lost),
- a class was lost at the last tick: two candidates reached one optimum, or a solve failed
  (a basin that closes may open again elsewhere),
- an obstacle starts to matter: a mover comes within ``PlannerConfig.relevance_range_m`` of
  the robot's predicted path, or a static obstacle within the multi-start range, that did
  not matter within ``PlannerConfig.relevance_memory_s`` (in a crowd, walkers step out of the
  relevance range and back; the one coming back is the one the kept candidates were solved
  with: measured under ``improved`` (3 s, six samples) on four 10-walker circle crossings,
  the full multi-starts fell from 39 % to 34 % of the ticks, the median decision from 6.3 to
  5.3 ms; ``paper`` keeps one sample, the rule before),
- ``PlannerConfig.multistart_period_s`` has passed since the last full multi-start (a new
  minimum can open without a new obstacle, as an obstacle moves).

When the one kept plan drove straight (its wheels' increments within 0.01 m/s of each other)
and its warm start near an obstacle now turns, the two swerves are solved beside it
(``opening_solves``, :meth:`casadi_gpc.planner.gpc.GPCController.plan_persistent`): a head-on mover
puts a straight plan on the ridge between passing left and passing right, where a warm start
falls to either side by the solver's round-off; the swerves find both sides and a tie goes to
the right, as in the full multi-start. (Solving them whenever a single candidate was kept
doubled the median decision.)

Candidates that reach the same optimum (increments within :data:`SAME_PLAN_MPS`) are one
class: the first in tie order stays. A candidate whose solve fails is dropped. Far from
every obstacle only the incumbent is kept. The cheapest survivor wins, exact ties going to
the earlier start in :data:`casadi_gpc.planner.guesses.TIE_ORDER` (then the previous plan), as in
the full multi-start.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .guesses import TIE_ORDER

__all__ = ["CandidateSet", "SAME_PLAN_MPS", "WARM", "START_ORDER", "shift"]

SAME_PLAN_MPS = 1e-4
"""Two solutions whose increments differ by less than this (m/s, every entry) are one."""
WARM = "warm"
"""The class of the previous plan shifted (last in tie order, as in the full multi-start)."""
START_ORDER = (*TIE_ORDER, WARM)


def shift(plan, H: int):
    """``(u0, lam_x, lam_g)``: a solution shifted by one step, the last increment zero."""
    u = np.concatenate([np.asarray(plan.u)[2:], np.zeros(2)])
    if plan.lam_x is None or plan.lam_g is None:
        return u, None, None
    return u, np.concatenate([plan.lam_x[2:], np.zeros(2)]), np.concatenate([plan.lam_g[2:], np.zeros(2)])


@dataclass
class CandidateSet:
    """The kept solutions of one planner (see the module text).

    Parameters
    ----------
    horizon : int
        H, the plans' number of steps.
    period_steps : int
        Ticks between full multi-starts while obstacles are near.
    """

    horizon: int
    period_steps: int
    prune_ratio: float | None = None
    """Candidates dearer than the best by more than this fraction are let go (None: kept)."""
    memory_steps: int = 1
    """An obstacle that mattered at any of the last this many ticks is not new when it
    matters again (1: only the last tick counts)."""
    plans: list = field(default_factory=list)
    """The kept candidates (``Plan``), in tie order."""
    _seen: dict = field(default_factory=dict)
    """Each obstacle that mattered: the last tick it did."""
    _tick: int = 0
    _since_full: int = 0
    _force_full: bool = False
    reason: str = ""
    """Why the last tick's full multi-start was due (empty when it was not)."""

    def reset(self) -> None:
        self.plans = []
        self._seen = {}
        self._tick = 0
        self._since_full = 0
        self._force_full = False

    def restart_from(self, plan) -> None:
        """After a tick whose every solve failed: ``plan`` (the previous one, shifted by the
        step it was used for) is the only start kept, and the next tick is a full multi-start."""
        self.plans = [plan]
        self._force_full = True

    @property
    def incumbent(self):
        """The candidate chosen at the last tick (None before any)."""
        return self.plans[0] if self.plans else None

    def full_multistart_due(self, near: bool, near_ids: frozenset) -> bool:
        """Whether this tick solves the fixed guesses as well (module text)."""
        # new: not among those that mattered at any of the last memory_steps ticks (a walker
        # that steps out of the relevance range and back is the one the candidates know)
        self._tick += 1
        seen, tick = self._seen, self._tick
        appeared = any(tick - seen.get(k, -10 ** 9) > self.memory_steps for k in near_ids)
        for k in near_ids:
            seen[k] = tick
        if len(seen) > 2 * len(near_ids) + 32:  # forget who left long ago (a long run meets many)
            self._seen = {k: t for k, t in seen.items() if tick - t <= self.memory_steps}
        if not self.plans or self._force_full:
            self.reason = "no candidate" if not self.plans else "a class lost"
            self._force_full = False
            return True
        self.reason = "" if not near else "an obstacle came to matter" if appeared else (
            "period" if self._since_full + 1 >= self.period_steps else "")
        return bool(self.reason)

    def starts(self, near: bool, full: bool) -> list[tuple[str, tuple]]:
        """This tick's warm starts: ``(class, (u0, lam_x, lam_g))`` of each kept candidate
        shifted (only the incumbent's when a full multi-start follows or nothing is near)."""
        if full or not near:  # the previous plan, as the full multi-start warm-starts it
            return [(WARM, shift(c, self.horizon)) for c in self.plans[:1]]
        return [(c.guess, shift(c, self.horizon)) for c in self.plans]

    def update(self, solved: list, full: bool, tie_relative: float):
        """Keep this tick's successful solutions, one per optimum, in tie order; return the
        cheapest (exact ties to the earlier class), or None when every solve failed."""
        self._since_full = 0 if full else self._since_full + 1
        before = len(self.plans)
        ok = sorted((c for c in solved if c.success), key=lambda c: _rank(c.guess))
        kept = []
        for c in ok:
            u = np.asarray(c.u)
            if any(np.max(np.abs(u - np.asarray(k.u))) <= SAME_PLAN_MPS for k in kept):
                continue
            kept.append(c)
        best = None
        for c in kept:
            if best is None or c.cost < best.cost - tie_relative * abs(best.cost):
                best = c
        if not full and len(kept) < before:
            self._force_full = True  # a class was lost (merged into another, or failed): look again
        if best is not None and self.prune_ratio is not None:  # far dearer than the best: let go
            kept = [c for c in kept if c is best or c.cost <= (1.0 + self.prune_ratio) * abs(best.cost)]
        # the incumbent first, then the rest in tie order (identity, not dataclass equality)
        self.plans = [best] + [c for c in kept if c is not best] if best is not None else kept
        return best


def _rank(name: str) -> int:
    return START_ORDER.index(name) if name in START_ORDER else len(START_ORDER)


STRAIGHT_MPS = 0.01
"""A plan whose two wheels' increments differ by at most this at every step drives straight."""


def fell_off_a_ridge(previous, solved) -> bool:
    """Whether the one kept plan drove straight and its warm start now turns: a head-on mover
    puts a straight plan on the ridge between passing left and right, and the warm start falls
    to either side by the solver's round-off (IPOPT passed Fig. 7.1 on the left, the SQP on the
    right). A straight plan that starts to turn for another reason (an obstacle coming
    closer) costs two solves more at that one step."""
    if previous is None or turns(previous.u):
        return False
    return any(c.success and turns(c.u) for c in solved)


def turns(u) -> bool:
    """Whether the plan's two wheels' increments differ by more than :data:`STRAIGHT_MPS` at
    some step (``u``: the increments, right and left interleaved)."""
    u = np.asarray(u)
    return bool(np.max(np.abs(u[0::2] - u[1::2])) > STRAIGHT_MPS)
