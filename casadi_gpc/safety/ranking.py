"""Which of a check's sequences is the best, compiled (numba): the index that
:meth:`~casadi_gpc.safety.check.TrajectoryCheck._pick` and the searched way out take from
:meth:`~casadi_gpc.safety.clearances.Clearances.clearances`' numbers, by the check's order
(one that keeps the margin, the largest smallest clearance among those; else the latest to drive
into a contact within the commitment time, then the longest clear of the expected discs, then
the latest to move towards a person inside their uncertain disc within the commitment time (the
same as the first key unless the check's ``robust_drive_ties`` is on), then the longest off the
fixed obstacles, then the longest keeping the margin, then the largest
smallest clearance; the first on a tie, clearances within :data:`TIE_M` a tie).

The numpy form it replaces took some ten whole-array calls a pick (three to five picks in a
decision whose command fails the check); ``tests/test_safety_ranking.py`` keeps it as the
reference the compiled one is held to, index for index. Only
comparisons, maxima and one subtraction (the tie's): the same numbers, NaN included (numpy's
maximum is NaN where a NaN is among the values).

The candidate's limits in plain floats (:func:`within_limits_floats`) are here too: the
numpy form's comparisons on the maxima (kept in the same test), one value at a time.
"""
from __future__ import annotations

import numpy as np
from numba import njit, types

__all__ = ["TIE_M", "pick_index", "best_unsafe_index", "within_limits_floats"]

TIE_M = 1e-9
"""Sequences whose smallest clearances differ by less than this are a tie (m)."""

_I = types.Array(types.int64, 1, "A", readonly=False)
_F = types.Array(types.float64, 1, "A", readonly=False)


@njit(types.int64(types.boolean[::1], _F), cache=True)
def _best(among, cmin):  # pragma: no cover (compiled)
    """``np.argmax(among & (cmin >= cmin[among].max() - TIE_M))``, ``among`` not empty."""
    top = -np.inf
    for i in range(cmin.shape[0]):
        if among[i]:
            v = cmin[i]
            if v != v:  # numpy's maximum of values with a NaN is NaN: no index passes, argmax is 0
                return 0
            if v > top:
                top = v
    floor = top - TIE_M
    for i in range(cmin.shape[0]):
        if among[i] and cmin[i] >= floor:
            return i
    return 0


@njit(cache=True)
def _keep_top(first, key):  # pragma: no cover (compiled)
    """``first &= key == key[first].max()``, ``first`` not empty."""
    top = -1
    seen = False
    for i in range(first.shape[0]):
        if first[i] and (not seen or key[i] > top):
            top, seen = key[i], True
    for i in range(first.shape[0]):
        first[i] = first[i] and key[i] == top


@njit(types.int64(_F, _I, _I, _I, _I, _I, types.int64), cache=True)
def best_unsafe_index(cmin, kept, contact, fixed, drives, rdrives, commit):  # pragma: no cover (compiled)
    """The index of the best of sequences that all lose the margin (the module's order);
    ``commit`` the commitment time's chord (``drives`` and ``rdrives`` above it count as it)."""
    M = cmin.shape[0]
    first = np.empty(M, np.bool_)
    top = drives[0] if drives[0] < commit else commit
    for i in range(1, M):
        d = drives[i] if drives[i] < commit else commit
        if d > top:
            top = d
    for i in range(M):
        first[i] = (drives[i] if drives[i] < commit else commit) == top
    _keep_top(first, contact)
    rd = np.empty(M, np.int64)
    for i in range(M):
        rd[i] = rdrives[i] if rdrives[i] < commit else commit
    _keep_top(first, rd)
    _keep_top(first, fixed)
    _keep_top(first, kept)
    return _best(first, cmin)


@njit(types.int64(_F, _I, _I, _I, _I, _I, types.int64, types.int64), cache=True)
def pick_index(cmin, kept, contact, fixed, drives, rdrives, n_chords, commit):  # pragma: no cover (compiled)
    """The best sequence's index (the module's order; 0 for a single one): ``kept`` equal to
    ``n_chords`` keeps the margin over the horizon."""
    M = cmin.shape[0]
    if M <= 1:
        return 0
    safe = np.empty(M, np.bool_)
    any_safe = False
    for i in range(M):
        safe[i] = kept[i] == n_chords
        any_safe = any_safe or safe[i]
    if any_safe:
        return _best(safe, cmin)
    return best_unsafe_index(cmin, kept, contact, fixed, drives, rdrives, commit)


def within_limits_floats(v0r: float, v0l: float, rows: list, dv_tol: float, vmax_tol: float) -> bool:
    """Whether the finite wheel speeds ``rows`` (``[[vr, vl], ...]``, plain floats), from
    ``(v0r, v0l)``, keep the speed limit ``vmax_tol`` and the rate limit ``dv_tol`` (each with
    its 1e-9 tolerance): each of the numpy form's comparisons on a maximum, made on every value
    (the maximum is one of them)."""
    prev_r, prev_l = v0r, v0l
    for r, l in rows:
        if abs(r) > vmax_tol or abs(l) > vmax_tol or abs(r - prev_r) > dv_tol or abs(l - prev_l) > dv_tol:
            return False
        prev_r, prev_l = r, l
    return True
