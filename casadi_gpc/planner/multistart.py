"""The planner's multi-start schedule, which guesses a control step solves: the warm start and
the fixed guesses (:meth:`MultiStart.plan`), or the persistent candidates with a full
multi-start when one falls due (:meth:`MultiStart.plan_persistent`), or spread over ticks
(``PlannerConfig.cold_starts``). Mixed into :class:`casadi_gpc.planner.gpc.GPCController`,
whose NLP, solves (``solve_many``), candidates, counters and walls in the NLP's slots it uses."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .candidates import fell_off_a_ridge, shift
from .guesses import TIE_ORDER, fitted_guesses, initial_guesses, plan_meets_walls, swerve_guesses
from ..problem.cost import to_world
from ..solvers import SolveResult

__all__ = ["MultiStart", "Plan", "TIE_RELATIVE"]

TIE_RELATIVE = 1e-7  # candidates closer than this in cost are a tie; the earlier one wins


@dataclass(frozen=True)
class Plan(SolveResult):
    """One solved (or failed) control sequence: a solver's result and the guess it started from."""

    guess: str = ""


class MultiStart:
    """Which starts a step solves, and which plan it keeps (module docstring)."""

    def plan(self, p: np.ndarray, x0: np.ndarray, ref_speed_mps: float, multistart: bool,
             warm: Plan | None = None, walls=None) -> tuple[Plan, list[Plan]]:
        """Solve from the warm start and, if ``multistart``, from the fixed guesses; keep the
        cheapest successful plan. Exact ties keep the earliest guess (swerve right first).
        ``walls``: the wall segments in ``p``'s slots (``(ax, ay, bx, by)`` each), whose
        crossing guesses are not solved, as :meth:`decide` leaves them out (None: those of
        the last :meth:`pose`)."""
        self._use_for(p)
        if walls is not None:
            self._walls_in_slots = list(walls)
        # The warm start is solved first (the likeliest answer, when the budget is short);
        # the candidates keep the guesses-then-warm order that breaks ties.
        starts = [] if warm is None else [("warm", *shift(warm, self.config.horizon))]
        if multistart or warm is None:
            starts += self._guess_starts(p, x0, ref_speed_mps, keep_one=not starts)
        solved = self.solve_many(p, starts)
        candidates = [c for c in solved if c.guess != "warm"] + [c for c in solved if c.guess == "warm"]
        best = None
        for c in candidates:
            if not c.success:
                continue
            if best is None or c.cost < best.cost - TIE_RELATIVE * abs(best.cost):
                best = c
        return best, candidates

    def plan_persistent(self, p: np.ndarray, x0: np.ndarray, ref_speed_mps: float, near: bool,
                        relevant: frozenset) -> tuple[Plan, list[Plan]]:
        """The persistent candidates' tick (:mod:`casadi_gpc.planner.candidates`): each kept
        candidate warm-started, or, when due, the full multi-start of :meth:`plan`.
        ``near``: obstacles within the multi-start range; ``relevant``: the obstacles that
        matter now (movers within ``relevance_range_m`` of the predicted path, static ones
        near), whose newcomers make a full multi-start due. With ``PlannerConfig.cold_starts``
        the multi-start is spread over ticks (:meth:`_plan_spread`)."""
        if self.config.cold_starts is not None:
            return self._plan_spread(p, x0, ref_speed_mps, near, relevant)
        cs = self.candidates
        full = cs.full_multistart_due(near, relevant)
        previous = cs.incumbent
        starts = [(name, u0, lam_x, lam_g) for name, (u0, lam_x, lam_g) in cs.starts(near, full)]
        if full:  # known now: the fixed guesses go with the warm starts, in one batch
            starts += self._guess_starts(p, x0, ref_speed_mps, keep_one=not starts)
        solved = self.solve_many(p, starts)
        if not full and near and len(cs.plans) == 1 and fell_off_a_ridge(previous, solved):
            solved = self._opening_solves(p, x0, ref_speed_mps) + solved
        if not full and near and self._surprised(previous, solved):
            full = True  # dearer than expected: look for a minimum no kept candidate is in
            cs.reason = "surprise"
            solved += self.solve_many(p, self._guess_starts(p, x0, ref_speed_mps, keep_one=False))
        if full:
            self._count_multistart(cs.reason)
        return cs.update(solved, full, TIE_RELATIVE), solved

    def _plan_spread(self, p, x0, ref_speed_mps: float, near: bool, relevant: frozenset) -> tuple[Plan, list[Plan]]:
        """:meth:`plan_persistent` with at most ``cold_starts`` fixed guesses a tick: a full
        multi-start that falls due queues every fixed guess (unless a cycle is under way, which
        it joins), and each tick solves the next ``cold_starts`` of the queue beside the warm
        starts of every kept candidate; the tick's guesses count as a multi-start for the
        candidates (a class that merges into a guess's optimum is not lost). The surprise
        (a warm start dearer than expected) queues a cycle too, and so does a kept plan through a
        wall (:func:`plan_meets_walls`: no minimum to keep). Counted: ``full_multistarts``
        (cycles begun), ``queued_guesses`` (guesses solved at a later tick than it began at)."""
        cs, K = self.candidates, self.config.cold_starts
        due, previous = cs.full_multistart_due(near, relevant), cs.incumbent
        through = plan_meets_walls(self.problem.config, self.robot, x0, previous, self._walls_in_slots)
        if not near and cs.plans and not through:
            self._pending = []  # far from everything, its plan off the walls: the one minimum
        if (due or through) and not self._pending:
            self._pending = self._cycle()
            self._count_multistart(cs.reason if due else "through_a_wall")
        batch = self._take_pending(K, began=due)
        starts = [(name, u0, lam_x, lam_g) for name, (u0, lam_x, lam_g) in cs.starts(near, False)]
        guesses = self._queued_starts(p, x0, ref_speed_mps, batch, keep_one=not starts)
        solved = self.solve_many(p, starts + guesses)
        if not batch and near and len(cs.plans) == 1 and fell_off_a_ridge(previous, solved):
            solved = self._opening_solves(p, x0, ref_speed_mps) + solved
        if not batch and near and self._surprised(previous, solved):
            self._pending = self._cycle()  # look for a minimum no kept candidate is in
            self._count_multistart("surprise")
            batch = self._take_pending(K, began=True)
            solved += self.solve_many(p, self._queued_starts(p, x0, ref_speed_mps, batch, keep_one=False))
        return cs.update(solved, bool(batch), TIE_RELATIVE), solved

    def _queued_starts(self, p, x0, ref_speed_mps: float, batch: list, keep_one: bool) -> list[tuple]:
        """The queued guesses ``batch``'s starts; for one left out (a wall), the queue's next
        (``batch`` grows by it): a tick still solves its ``cold_starts``."""
        starts, want = self._guess_starts(p, x0, ref_speed_mps, batch, keep_one), len(batch)
        while len(starts) < want and self._pending:
            more, self._pending = self._pending[:1], self._pending[1:]
            batch += more
            starts += self._guess_starts(p, x0, ref_speed_mps, more, keep_one=False)
        return starts

    def _surprised(self, previous, solved) -> bool:
        """Whether this tick's best warm start costs more than ``PlannerConfig.surprise_ratio``
        above the last tick's best (``previous``): a minimum may have opened that no kept
        candidate is in."""
        surprise = self.config.surprise_ratio
        if surprise is None or previous is None:
            return False
        best = min((c.cost for c in solved if c.success), default=math.inf)
        return not best <= (1.0 + surprise) * abs(previous.cost) + 1e-9

    def _cycle(self) -> list[str]:
        """The fixed guesses of one spread multi-start, in tie order."""
        return [name for name in TIE_ORDER if name in self.config.guesses]

    def _take_pending(self, k: int, began: bool) -> list[str]:
        """The next ``k`` queued guesses (removed from the queue); ``began``: this tick began
        the cycle (the others are counted ``queued_guesses``). Within
        ``PlannerConfig.cold_start_gap`` ticks of the last guess solved none, unless ``began``
        (counted ``deferred_guesses``)."""
        if not began and self._pending and self._since_guess < self.config.cold_start_gap:
            self._since_guess += 1
            self.counters["deferred_guesses"] = self.counters.get("deferred_guesses", 0) + 1
            return []
        batch, self._pending = self._pending[:k], self._pending[k:]
        self._since_guess = 0 if batch else self._since_guess + 1
        if batch and not began:
            self.counters["queued_guesses"] = self.counters.get("queued_guesses", 0) + len(batch)
        return batch

    def _count_multistart(self, reason: str) -> None:
        self.counters["full_multistarts"] += 1
        key = "multistart_" + reason.replace(" ", "_")
        self.counters[key] = self.counters.get(key, 0) + 1

    def _opening_solves(self, p, x0, ref_speed_mps: float) -> list[Plan]:
        """The two swerves, solved when the one kept plan fell off the ridge between passing
        left and right (:func:`fell_off_a_ridge`); first in the list, so a tie goes right."""
        openings = swerve_guesses(self.config, self.robot, x0, ref_speed_mps)
        out = self.solve_many(p, [(name, openings[name], None, None) for name in ("swerve_right", "swerve_left")])
        self.counters["opening_solves"] = self.counters.get("opening_solves", 0) + len(out)
        return out

    def _guess_starts(self, p, x0, ref_speed_mps: float, names=None, keep_one: bool = True) -> list[tuple]:
        """The fixed guesses as starts ``(name, u0, None, None)``, in tie order (``names``:
        only those), fitted to the NLP's walls (:func:`fitted_guesses`, counted); all of them
        as they are if none fits and ``keep_one`` (nothing else to start from)."""
        if names is not None and not names:
            return []
        ref_poses = to_world(np.asarray(p[self._ref_slice]).reshape(self.config.horizon, 3), x0)  # steps 1..H
        guesses = initial_guesses(self.problem, x0, ref_speed_mps, ref_poses, names)
        if self._walls_in_slots:
            fitted, narrowed = fitted_guesses(self.problem, x0, ref_speed_mps, ref_poses, guesses, self._walls_in_slots)
            if fitted or not keep_one:
                for key, n in (("guesses_through_walls", len(guesses) - len(fitted)), ("guesses_narrowed", narrowed)):
                    self.counters[key] = self.counters.get(key, 0) + n
                guesses = fitted
        return [(name, u0, None, None) for name, u0 in guesses.items()]
