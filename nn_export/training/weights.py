"""Per-sample weights of the training loss (numpy only).

Plain regression averages the answers of two optima that cost nearly the same: where the
GPC's multi-start finds passing left and passing right (or braking and going on) within a
hair of each other, neighbouring situations are labelled with either, and a network that
fits both answers in between, straight into the obstacle (Milios et al. 2025; measured in
``docs/nn-crowds.md``, "Averaging the two sides"). The datasets keep every start's cost
(``candidate_costs``), so how close the runner-up optimum came is known for each label.

:func:`cost_gap_weights` gives such near-tie labels less weight, so that the clear answers
around them decide what the network does there.
"""
from __future__ import annotations

import numpy as np

__all__ = ["cost_gap", "cost_gap_weights", "WEIGHT_FLOOR", "SAME_OPTIMUM_RELATIVE"]

SAME_OPTIMUM_RELATIVE = 1e-6
"""A start whose cost is within this relative distance of the chosen one found the same
optimum (the labeller's starts agree to about 1e-9)."""

WEIGHT_FLOOR = 0.1
"""The least weight: a near tie still counts a tenth of a clear label."""


def cost_gap(candidate_costs: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """How much dearer, relative to the chosen cost, the cheapest other optimum that the
    multi-start found is (``inf`` where every converged start found the chosen one).
    ``candidate_costs``: ``(n, G)``, NaN for a start that failed; ``cost``: ``(n,)``."""
    cc = np.asarray(candidate_costs, dtype=float)
    c = np.asarray(cost, dtype=float)[:, None]
    with np.errstate(invalid="ignore"):
        rel = (cc - c) / np.maximum(np.abs(c), 1e-12)
    other = np.where(rel > SAME_OPTIMUM_RELATIVE, rel, np.inf)   # NaN (failed) compares false
    return other.min(axis=1) if other.shape[1] else np.full(len(c), np.inf)


def cost_gap_weights(candidate_costs: np.ndarray, cost: np.ndarray, scale: float) -> np.ndarray:
    """``clip(gap / scale, WEIGHT_FLOOR, 1)`` per sample, :func:`cost_gap`'s gap: a label
    whose runner-up optimum is ``scale`` (relative) dearer or more counts fully, a near tie
    down to :data:`WEIGHT_FLOOR`."""
    if not scale > 0:
        raise ValueError(f"the cost-gap scale must be positive, got {scale}")
    return np.clip(cost_gap(candidate_costs, cost) / scale, WEIGHT_FLOOR, 1.0)
