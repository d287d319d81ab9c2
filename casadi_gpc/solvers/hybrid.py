"""One backend for warm starts and another for cold starts."""
from __future__ import annotations

from dataclasses import replace

from .base import Backend, SolveResult

__all__ = ["HybridBackend"]


class HybridBackend(Backend):
    """A warm start (a previous plan: ``lam_x`` given) by ``warm``, a cold start (a guess) by
    ``cold``. Measured (docs/solvers.md): the SQP reaches IPOPT's answer from every warm
    start and is the fastest there, but from a far guess it lands in a worse local minimum
    more often than IPOPT; fatrop, an interior-point method like IPOPT, follows IPOPT's
    basins from the guesses. A warm start the SQP fails on (a start deep inside a stiff
    penalty, mostly) is solved again by ``cold`` from the same start, in the same call: a
    compiled fatrop solve costs a few ms where the planner's IPOPT backup, uncompiled, cost
    48 ms in crowds. ``retries`` counts them."""

    def __init__(self, name: str, warm: Backend, cold: Backend):
        super().__init__(name, warm.problem)
        self.warm, self.cold = warm, cold
        self.compiled = warm.compiled and cold.compiled
        self.notes = [f"warm starts: {warm.name} ({'; '.join(warm.notes)})",
                      f"cold starts: {cold.name} ({'; '.join(cold.notes)})",
                      f"a warm start {warm.name} fails on: {cold.name} from the same start"]
        self.retries = 0

    def fork(self) -> "HybridBackend | None":
        warm, cold = self.warm.fork(), self.cold.fork()
        return None if warm is None or cold is None else HybridBackend(self.name, warm, cold)

    def _solve(self, p, u0, lam_x, lam_g) -> SolveResult:
        if lam_x is None:
            return self.cold._solve(p, u0, lam_x, lam_g)
        first = self.warm._solve(p, u0, lam_x, lam_g)
        if first.success:
            return first
        self.retries += 1
        again = self.cold._solve(p, u0, None, None)
        return replace(again, status=f"{self.cold.name} after {self.warm.name}: {first.status} -> {again.status}",
                       solve_time_s=first.solve_time_s + again.solve_time_s)
