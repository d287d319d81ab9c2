"""One backend for warm starts and another for cold starts."""
from __future__ import annotations

from .base import Backend, SolveResult

__all__ = ["HybridBackend"]


class HybridBackend(Backend):
    """A warm start (a previous plan: ``lam_x`` given) by ``warm``, a cold start (a guess) by
    ``cold``. Measured (docs/solvers.md): the SQP reaches IPOPT's answer from every warm
    start and is the fastest there, but from a far guess it lands in a worse local minimum
    more often than IPOPT; fatrop, an interior-point method like IPOPT, follows IPOPT's
    basins from the guesses."""

    def __init__(self, name: str, warm: Backend, cold: Backend):
        super().__init__(name, warm.problem)
        self.warm, self.cold = warm, cold
        self.compiled = warm.compiled and cold.compiled
        self.notes = [f"warm starts: {warm.name} ({'; '.join(warm.notes)})",
                      f"cold starts: {cold.name} ({'; '.join(cold.notes)})"]

    def _solve(self, p, u0, lam_x, lam_g) -> SolveResult:
        return (self.warm if lam_x is not None else self.cold)._solve(p, u0, lam_x, lam_g)
