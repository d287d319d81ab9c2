"""The network's input layouts: which inputs, in which order, what an empty slot holds
(numpy only). The feature values are :mod:`nn_export.runtime.features`.

Layouts
-------
``paper`` (17 inputs when H = 6; ``11 + H`` in general), the paper's Fig. 4:

===  =========================  ======  ================================================
#    name                       unit    meaning
===  =========================  ======  ================================================
0    ``v_right_prev_mps``       m/s     right wheel speed applied over the last interval
1    ``v_left_prev_mps``        m/s     left wheel speed applied over the last interval
2    ``mov1_x_m``               m       nearest moving obstacle, EKF position now, local x
3    ``mov1_y_m``               m       ... local y
4    ``mov1_speed_mps``         m/s     EKF speed V(k+1) (= V(k), constant-speed model)
5    ``mov1_heading_rad``       rad     EKF heading theta(k+1) = theta + dtheta, relative to
                                        the robot's heading, wrapped to [0, 2 pi)
6    ``mov1_turn_rad``          rad     EKF heading increment per sample dtheta(k+1)
7    ``ref_x_m``                m       first desired point (step 1), local x
8    ``ref_y_m``                m       ... local y
9    ``ref_heading_rad``        rad     its heading relative to the robot's, in (-pi, pi]
10+  ``ref_curvature_{k}_1pm``  1/m     k = 1..H: curvature of the arc that joins desired
                                        pose k-1 to desired pose k (pose 0: where the
                                        reference point is now)
last ``ref_speed_mps``          m/s     mean desired speed: arc length from pose 0 to pose H
                                        divided by H T
===  =========================  ======  ================================================

``multi`` (``6 + 8 K_moving + 4 K_static + H`` inputs; 48 for K = 3, H = 6; 54 for H = 12):
the two wheel speeds; then for each of the K nearest moving obstacles ``movj_present`` (1 or 0), ``x``,
``y``, ``speed``, ``heading``, ``turn`` (as above), ``radius_m`` and ``pos_std_m`` (the RMS
standard deviation of its predicted position at step H, sqrt(trace(cov_H)/2), which sets the
planner's uncertainty weight); then for each of the K nearest static obstacles
``staj_present``, ``x``, ``y``, ``radius_m``; then the same reference block as ``paper``.
The paper layout has no radius and no uncertainty input (the paper's 17 inputs); its
network learns the average answer over the sampler's radius range.

``set`` (``6 + 9 (K_moving + K_static) + H`` inputs; 180 for 12 moving and 6 static slots,
H = 12): the obstacles as a set, for a network that encodes each one alike and pools them
(:mod:`nn_export.training.set_net`), so that their order does not matter. The two wheel
speeds; then K_moving moving and K_static static slots, every slot the same nine inputs
``present`` (1 or 0), ``x_m``, ``y_m`` (position now, local), ``vx_mps``, ``vy_mps`` (the EKF
velocity at heading theta + dtheta, in the robot's frame: no angle, so no wrap seam),
``turn_rad`` (dtheta per sample), ``radius_m``, ``pos_std_m`` (as ``multi``) and ``moving``
(1 for a moving obstacle, 0 for a static one, whose velocity, turn and uncertainty are 0);
then the reference block. An empty slot is all zeros: the network masks it out by its
``present`` input, so it holds no code at all.

``set-walls`` (``set`` + :data:`~nn_export.runtime.wall_scan.WALL_SECTORS` inputs; 204 for
H = 12): the ``set`` layout, then the walls as a range sensor would see them,
``wall_{k}_m`` for k = 0..23: the distance from the robot's centre to the nearest wall point in
the 15-degree sector centred on direction k * 15 degrees (counter-clockwise from straight
ahead), capped at :data:`~nn_export.runtime.wall_scan.WALL_SCAN_RANGE_M` (4 m: no wall within
range). :mod:`nn_export.runtime.wall_scan` computes it from the map's wall segments. Without
walls every sector reads 4 m, so a situation without walls has the ``set`` layout's features
followed by 24 fours.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from .wall_scan import WALL_SCAN_RANGE_M, WALL_SECTORS, sector_mirror

__all__ = ["FEATURE_VERSION", "LAYOUTS", "WHEEL_INPUTS",
           "SET_ELEMENT", "SET_SLOTS", "OBSTACLE_RANGE_M", "CURVATURE_LIMIT_1PM",
           "FeatureLayout", "layout_for", "layout_from_dict"]

FEATURE_VERSION = 1
"""Bumped whenever the meaning of any feature changes; datasets and models carry it."""
LAYOUTS = ("paper", "multi", "set", "set-walls")
WHEEL_INPUTS = ("v_right_prev_mps", "v_left_prev_mps")
"""The first two inputs of every layout: the wheel speeds applied over the last interval."""
OBSTACLE_RANGE_M = 12.0
"""Obstacles farther than this from the robot are encoded as absent (and parked here)."""
CURVATURE_LIMIT_1PM = 5.0
"""Curvature features are clipped to +-this (a 0.2 m turning radius)."""
SET_ELEMENT = ("present", "x_m", "y_m", "vx_mps", "vy_mps", "turn_rad", "radius_m", "pos_std_m", "moving")
"""The inputs of one obstacle slot of the ``set`` layout, in order."""
SET_SLOTS = (12, 6)
"""The ``set`` layout's moving and static slots (the nearest obstacles fill them; the rest are
counted as dropped)."""


@dataclass(frozen=True)
class FeatureLayout:
    """Which inputs, in which order. ``name`` + ``version`` identify the meaning."""

    name: str
    horizon: int
    k_moving: int
    k_static: int
    version: int = FEATURE_VERSION
    range_m: float = OBSTACLE_RANGE_M
    curvature_limit_1pm: float = CURVATURE_LIMIT_1PM
    wall_sectors: int = 0
    """Sectors of the wall scan at the end of the input (``set-walls``); 0: the layout reads no walls."""
    wall_range_m: float = WALL_SCAN_RANGE_M
    """Where the wall scan stops (m): a sector without a wall within it reads this."""

    @cached_property
    def flags(self) -> bool:
        """Whether obstacle slots carry presence flags, radius and uncertainty (``multi``)."""
        return self.name == "multi"

    @cached_property
    def is_set(self) -> bool:
        """Whether every obstacle slot is one element of a set (``set``: the same inputs for
        moving and static obstacles, zeros when empty)."""
        return self.name in ("set", "set-walls")

    @cached_property
    def set_slots(self) -> tuple[int, int, int]:
        """``(first input, number of slots, inputs per slot)`` of the obstacle set (``set``)."""
        if not self.is_set:
            raise ValueError(f"layout {self.name!r} has no obstacle set")
        return 2, self.k_moving + self.k_static, len(SET_ELEMENT)

    @cached_property
    def feature_names(self) -> tuple[str, ...]:
        names = list(WHEEL_INPUTS)
        if self.is_set:
            names += [f"mov{j}_{b}" for j in range(1, self.k_moving + 1) for b in SET_ELEMENT]
            names += [f"sta{j}_{b}" for j in range(1, self.k_static + 1) for b in SET_ELEMENT]
        for j in range(1, (0 if self.is_set else self.k_moving) + 1):
            block = ["x_m", "y_m", "speed_mps", "heading_rad", "turn_rad"]
            if self.flags:
                block = ["present"] + block + ["radius_m", "pos_std_m"]
            names += [f"mov{j}_{b}" for b in block]
        for j in range(1, (0 if self.is_set else self.k_static) + 1):
            names += [f"sta{j}_{b}" for b in ("present", "x_m", "y_m", "radius_m")]
        names += ["ref_x_m", "ref_y_m", "ref_heading_rad"]
        names += [f"ref_curvature_{k}_1pm" for k in range(1, self.horizon + 1)]
        names += ["ref_speed_mps"]
        names += [f"wall_{k}_m" for k in range(self.wall_sectors)]
        return tuple(names)

    @property
    def size(self) -> int:
        return len(self.feature_names)

    @property
    def moving_width(self) -> int:
        return len(SET_ELEMENT) if self.is_set else 8 if self.flags else 5

    @cached_property
    def absent_moving(self) -> tuple[float, ...]:
        """The inputs of an empty moving-obstacle slot: a standing obstacle parked at the edge
        of the range straight behind the robot (``multi``: present 0, radius 0, pos_std 0)."""
        if self.is_set:
            return (0.0,) * len(SET_ELEMENT)
        vals = (-self.range_m, 0.0, 0.0, math.pi, 0.0)
        return (0.0, *vals, 0.0, 0.0) if self.flags else vals

    @cached_property
    def absent_static(self) -> tuple[float, ...]:
        """The inputs of an empty static-obstacle slot (present 0, parked behind, radius 0;
        ``set``: zeros)."""
        if self.is_set:
            return (0.0,) * len(SET_ELEMENT)
        return (0.0, -self.range_m, 0.0, 0.0)

    @cached_property
    def _absent_obstacles(self) -> tuple[float, ...]:
        """The obstacle slots of a situation without obstacles (all of them empty)."""
        return (*self.absent_moving * self.k_moving, *self.absent_static * self.k_static)

    @cached_property
    def _mirror(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(permutation, signs, heading indices) of the mirror map."""
        names = self.feature_names
        perm = np.arange(self.size)
        perm[0], perm[1] = 1, 0
        signs = np.ones(self.size)
        for i, n in enumerate(names):
            if (n.endswith(("_y_m", "_turn_rad", "_vy_mps")) or n in ("ref_heading_rad",)
                    or n.startswith("ref_curvature_")):
                signs[i] = -1.0
        heading = np.array([i for i, n in enumerate(names) if n.endswith("_heading_rad") and n.startswith("mov")],
                           dtype=int)
        if self.wall_sectors:  # sector k of the mirrored world is sector (n - k) mod n of this one
            first = self.index("wall_0_m")
            perm[first:first + self.wall_sectors] = first + sector_mirror(self.wall_sectors)
        return perm, signs, heading

    def index(self, name: str) -> int:
        return self.feature_names.index(name)

    def to_dict(self) -> dict:
        """What travels with every dataset and model."""
        return {"name": self.name, "version": self.version, "horizon": self.horizon,
                "k_moving": self.k_moving, "k_static": self.k_static, "range_m": self.range_m,
                "curvature_limit_1pm": self.curvature_limit_1pm, "size": self.size,
                **({"wall_sectors": self.wall_sectors, "wall_range_m": self.wall_range_m} if self.wall_sectors else {}),
                "feature_names": list(self.feature_names)}


def layout_for(name: str, horizon: int, k: int = 3) -> FeatureLayout:
    """The ``paper`` layout (one moving obstacle, no static), ``multi`` (``k`` of each),
    ``set`` (:data:`SET_SLOTS`; ``k`` unused) or ``set-walls`` (``set`` and the wall scan)."""
    if name not in LAYOUTS:
        raise ValueError(f"unknown feature layout {name!r} (choose from {', '.join(LAYOUTS)})")
    if int(horizon) < 1:
        raise ValueError(f"horizon must be at least 1, got {horizon}")
    if name == "paper":
        return FeatureLayout("paper", int(horizon), 1, 0)
    if name == "set":
        return FeatureLayout("set", int(horizon), *SET_SLOTS)
    if name == "set-walls":
        return FeatureLayout("set-walls", int(horizon), *SET_SLOTS, wall_sectors=WALL_SECTORS)
    if int(k) < 1:
        raise ValueError(f"k must be at least 1, got {k}")
    return FeatureLayout("multi", int(horizon), int(k), int(k))


def layout_from_dict(d: dict) -> FeatureLayout:
    """The layout a dataset or model was made with; refuses versions and names this code
    does not produce (one clear ``ValueError``)."""
    try:
        name, version, horizon = d["name"], int(d["version"]), int(d["horizon"])
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"feature layout description is incomplete: {d!r}") from None
    if version != FEATURE_VERSION:
        raise ValueError(f"feature layout {name!r} version {version} is not the version this code computes "
                         f"({FEATURE_VERSION})")
    lay = layout_for(name, horizon, int(d.get("k_moving", 3)))
    lay = replace(lay, k_moving=int(d.get("k_moving", lay.k_moving)), k_static=int(d.get("k_static", lay.k_static)),
                  range_m=float(d.get("range_m", lay.range_m)),
                  curvature_limit_1pm=float(d.get("curvature_limit_1pm", lay.curvature_limit_1pm)),
                  wall_sectors=int(d.get("wall_sectors", lay.wall_sectors)),
                  wall_range_m=float(d.get("wall_range_m", lay.wall_range_m)))
    names = d.get("feature_names")
    if names is not None and tuple(names) != lay.feature_names:
        raise ValueError(f"feature names of layout {name!r} v{version} do not match this code's")
    return lay
