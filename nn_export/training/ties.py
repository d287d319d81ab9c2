"""Near ties between passing an obstacle on the left and on the right, and the convention that
settles them (numpy only).

Where an obstacle blocks the desired path, the GPC's cost has a pass-left and a pass-right
minimum, and the planner keeps the cheaper one (an exact tie: the right, its guess order).
The answer jumps where the two costs cross, and a small network fitted to both sides of
that jump averages them (a straight answer, towards the obstacle) over the band of
situations its smoothness spans. Worse, the paper's inputs do not hold everything the
costs depend on (the obstacle's radius, the filter's uncertainty), so near the crossing
two situations with the same inputs can carry opposite labels; and the mirror image of an
exact tie is labelled with the other side although its inputs are the same.

The convention: where both sides were found and the pass on the right costs at most
``margin`` (relative) more than the pass on the left, the label is the pass on the right.
The mirror situation is labelled by the same rule applied to its own candidates (the
original's, mirrored: its right pass is the original's left pass), so a situation and its
mirror image are both labelled with the pass on the right inside the band, and the label
is a function of the situation. ``margin = 0`` is the planner's own rule (exact ties only).

"Passing on the right" (side +1): at the step of the plan's closest approach to the
obstacle's predicted position, the obstacle lies to the left of the desired direction of
travel there (the desired pose's heading at that step); -1 when it lies to the right. For
a head-on obstacle that is swerving right; for one crossing from the right, passing behind
it; from the left, passing in front of it (the mirror image of the last).
"""
from __future__ import annotations

import math

import numpy as np

__all__ = ["RIGHT", "LEFT", "passing_side", "prefers_right", "choose"]

RIGHT, LEFT = 1, -1


def passing_side(poses_m: np.ndarray, obstacle_means_m: np.ndarray, ref_headings_rad: np.ndarray) -> int:
    """The side the planned robot passes the obstacle on: :data:`RIGHT` (+1) or :data:`LEFT` (-1).

    Parameters
    ----------
    poses_m : array (H, >= 2)
        The plan's robot positions at steps 1..H, m.
    obstacle_means_m : array (H, 2)
        The obstacle's predicted positions at the same steps, m (a static obstacle: its
        position repeated).
    ref_headings_rad : array (H,)
        The desired headings at steps 1..H, rad.
    """
    d = np.asarray(obstacle_means_m, dtype=float)[:, :2] - np.asarray(poses_m, dtype=float)[:, :2]
    k = int(np.argmin(np.hypot(d[:, 0], d[:, 1])))
    h = float(np.asarray(ref_headings_rad, dtype=float)[k])
    cross = math.cos(h) * d[k, 1] - math.sin(h) * d[k, 0]
    return RIGHT if cross >= 0.0 else LEFT


def prefers_right(cost_right: float, cost_left: float, margin: float) -> bool:
    """Whether the convention takes the pass on the right: it costs at most ``margin``
    (relative to the cheaper of the two) more than the pass on the left."""
    return cost_right <= cost_left + margin * min(abs(cost_left), abs(cost_right)) + 1e-12


def choose(right, left, margin: float):
    """The answer under the convention between the best pass on the right and the best on the
    left (anything with a ``cost``); either may be None (that side was not found)."""
    if right is None or left is None:
        return right if left is None else left
    return right if prefers_right(right.cost, left.cost, margin) else left
