"""Typed data passed between the stages: observations in, decisions out."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from numbers import Integral, Real
from typing import Protocol

import numpy as np

from .finite import finite_real
from .reference import ReferencePath
from .robot import RobotState

__all__ = [
    "ObstacleMeasurement",
    "StaticObstacle",
    "Observation",
    "ObstacleForecast",
    "ControlDecision",
    "Policy",
    "ProtocolError",
    "checked_decision",
    "policy_class_name",
    "samples_since",
    "positive_seconds",
    "finite_real",
]


@dataclass(frozen=True)
class ObstacleMeasurement:
    """One moving obstacle as the sensor reports it this sample."""

    obstacle_id: int
    """The obstacle's track: the same integer for one obstacle from sample to sample (any integer
    type; anything else is refused by :class:`Observation`)."""
    position_m: tuple[float, float] | None
    """Measured position, or None when the measurement is missing."""
    radius_m: float


@dataclass(frozen=True)
class StaticObstacle:
    position_m: tuple[float, float]
    radius_m: float


@dataclass(frozen=True)
class Observation:
    """Everything a controller is told at one sample instant.

    Raises ``ValueError`` when the time or the robot's own state is not finite: no
    controller can answer that safely; and when an obstacle's size, or a static obstacle's
    place, is not a finite number (a radius not negative): no controller can keep clear of an
    obstacle of no known size, and the planner's solves all failed on one, braking for good; and
    when two moving obstacles share an id (the filters are kept by id: the two were fused into one
    phantom, its filter stepped twice a sample, a 3 m/s obstacle that sent the check layer into
    reverse, and neither person was where it was forecast); and when a moving obstacle's id is not
    an integer (a tracker's name, "person_3", failed deep in the network's features, and in the
    planner only once a wall came into view); and when a measured position is not two real numbers or
    None (:func:`_refuse_position`). A missing or non-finite obstacle *position measurement* is a
    sensor fault, not an error: the obstacle filters skip it and count it.
    """

    t_s: float
    robot: RobotState
    reference: ReferencePath
    moving: tuple[ObstacleMeasurement, ...] = ()
    static: tuple[StaticObstacle, ...] = ()
    walls: tuple[tuple[tuple[float, float], ...], ...] = ()
    """The map's walls, each a polyline of ``(x_m, y_m)`` points, known exactly. The check
    layer judges every option against them (:mod:`casadi_gpc.safety.walls`), the planner
    plans with them when its NLP has wall slots (``PlannerConfig.max_walls``); the networks
    do not read them yet (docs/buildings.md)."""

    def __post_init__(self):
        r = self.robot
        if not (math.isfinite(self.t_s) and math.isfinite(r.x_m) and math.isfinite(r.y_m)
                and math.isfinite(r.heading_rad) and math.isfinite(r.v_right_mps) and math.isfinite(r.v_left_mps)):
            raise ValueError(f"observation at t={self.t_s} s has a non-finite time or robot state: {r}")
        for m in self.moving:
            if not (m.radius_m >= 0 and math.isfinite(m.radius_m)):
                raise ValueError(f"observation at t={self.t_s} s: moving obstacle {m.obstacle_id} has radius "
                                 f"{m.radius_m!r} (a finite number, not negative)")
            z = m.position_m
            if z is not None and not (type(z) is tuple and len(z) == 2 and type(z[0]) is float and type(z[1]) is float):
                _refuse_position(m, self.t_s)
            if not isinstance(m.obstacle_id, Integral):
                raise ValueError(f"observation at t={self.t_s} s: moving obstacle id {m.obstacle_id!r} is a "
                                 f"{type(m.obstacle_id).__name__}, not an integer (an id is one obstacle's track, "
                                 f"an int: number the names a tracker gives)")
        if len(self.moving) > 1 and len({m.obstacle_id for m in self.moving}) < len(self.moving):
            seen, twice = set(), None
            for m in self.moving:
                if m.obstacle_id in seen:
                    twice = m.obstacle_id
                    break
                seen.add(m.obstacle_id)
            raise ValueError(f"observation at t={self.t_s} s: moving obstacle id {twice!r} is listed twice (an id "
                             f"is one obstacle's track: two people under one id were one phantom, stepped twice "
                             f"a sample)")
        for j, st in enumerate(self.static):
            x, y = st.position_m
            if not (st.radius_m >= 0 and math.isfinite(st.radius_m) and math.isfinite(x) and math.isfinite(y)):
                raise ValueError(f"observation at t={self.t_s} s: static obstacle {j} at {st.position_m!r} with radius "
                                 f"{st.radius_m!r} (finite numbers, the radius not negative)")
        if len(self.walls):
            object.__setattr__(self, "walls", _walls_as_tuples(self.walls, self.t_s))

    def with_wheels_within(self, max_wheel_speed_mps: float) -> "Observation | None":
        """This observation with the robot's wheel speeds held to ``max_wheel_speed_mps``
        where one reports more (a glitching encoder: the planner's every solve failed from a
        state its limits forbid, and its brake ramped down from 5 m/s); None where both are
        within it (float noise of 1e-9 m/s aside)."""
        r, v = self.robot, float(max_wheel_speed_mps)
        if abs(r.v_right_mps) <= v + 1e-9 and abs(r.v_left_mps) <= v + 1e-9:
            return None
        from dataclasses import replace
        held = replace(r, v_right_mps=min(max(r.v_right_mps, -v), v), v_left_mps=min(max(r.v_left_mps, -v), v))
        return replace(self, robot=held)


def _refuse_position(m: ObstacleMeasurement, t_s: float) -> None:
    """Raise ``ValueError`` unless ``m``'s position is two real numbers (a sequence or an array; NaN
    or infinite is a missing measurement, counted by the filters): until 2026-12-02 a position of
    strings ("1", "2") or of booleans was read as numbers, one of (None, 1.0) taken for a missing one,
    and a complex number or a word failed with an error that named neither the obstacle nor the time."""
    z = m.position_m
    ok = isinstance(z, np.ndarray) and z.shape == (2,) and z.dtype.kind in "fiu"
    if not ok and not isinstance(z, (str, bytes, np.ndarray)):
        try:
            ok = len(z) == 2 and all(isinstance(v, Real) and not isinstance(v, (bool, np.bool_)) for v in z)
        except TypeError:
            ok = False
    if not ok:
        import reprlib
        raise ValueError(f"observation at t={t_s} s: moving obstacle {m.obstacle_id!r} has position "
                         f"{' '.join(reprlib.repr(z).split())} (two numbers x, y in m, or None when not measured)")


_CHECKED_WALLS: list = [None]
"""The walls tuple last found valid by :func:`_walls_as_tuples`: a map of 20 000 segments took 2-3 ms
to check again at every observation (docs/buildings.md, "Maps of any size")."""


def _walls_as_tuples(walls, t_s: float) -> tuple:
    """``walls`` as a tuple of polylines, each a tuple of ``(x, y)`` float pairs, whatever
    sequences or arrays held them (lists, read from JSON, failed in the check layer as
    unhashable); a polyline of fewer than two points, a point that is not two numbers, or a
    number that is not finite refused (a NaN wall had the planner fail every solve; a
    one-point wall was dropped silently). Walls given as such tuples already are returned as
    they are."""
    if walls is _CHECKED_WALLS[0]:  # the map found valid last time: tuples of floats, it cannot have changed
        return walls
    try:
        if type(walls) is tuple and all(type(w) is tuple and len(w) >= 2 and all(
                type(p) is tuple and len(p) == 2 and type(p[0]) is float and type(p[1]) is float
                and math.isfinite(p[0]) and math.isfinite(p[1]) for p in w) for w in walls):
            _CHECKED_WALLS[0] = walls  # (kept alive: no other object can take its identity meanwhile)
            return walls
        out = []
        for i, w in enumerate(walls):
            pts = tuple((float(x), float(y)) for x, y in w)
            if len(pts) < 2:
                raise ValueError(f"wall {i} has {len(pts)} point(s): a wall is a polyline of at least two")
            if not all(math.isfinite(x) and math.isfinite(y) for x, y in pts):
                raise ValueError(f"wall {i} has a point that is not finite: {pts!r}")
            out.append(pts)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"observation at t={t_s} s: walls must be polylines of (x, y) points: {exc}") from None
    return tuple(out)


def positive_seconds(value) -> bool:
    """Whether ``value`` is a sample time: a :func:`finite_real` above 0 (``np.float32(0.5)``
    read from a config array was refused as "not a positive number")."""
    return finite_real(value) and value > 0


def samples_since(previous_t_s: float | None, t_s: float, sample_time_s: float) -> int:
    """How many samples of ``sample_time_s`` an observation at ``t_s`` comes after the one at
    ``previous_t_s`` (None: the first since a reset, 1): the gap rounded to whole samples, so a
    clock's jitter under half a sample counts as one, and a gap of k samples as k (k - 1 samples
    went without an observation: a dropped sensor frame, a decision loop that overran). Whatever
    is stepped once per sample (the obstacle filters, the reference clock) steps k times.

    Raises ``ValueError`` when ``t_s`` is not at least half a sample after ``previous_t_s``: a
    controller decides once per sample, and the filters would take a shorter interval (or time
    running backwards, a new episode without ``reset()``) for a whole sample."""
    if previous_t_s is None:
        return 1
    gap = t_s - previous_t_s
    if not gap >= 0.5 * sample_time_s:
        raise ValueError(f"an observation at t={t_s} s came {gap:.6g} s after the previous one (t={previous_t_s} s), "
                         f"less than half the sample time {sample_time_s} s: a controller decides once per sample "
                         f"(call reset() before a new episode)")
    return max(1, int(round(gap / sample_time_s)))


@dataclass(frozen=True)
class ObstacleForecast:
    """A moving obstacle's predicted positions over steps 1..H, from its EKF."""

    obstacle_id: int
    radius_m: float
    means_m: np.ndarray
    """Shape (H, 2)."""
    covs_m2: np.ndarray
    """Shape (H, 2, 2)."""


@dataclass(frozen=True)
class ControlDecision:
    """A controller's answer: the wheel speeds for the next sample interval."""

    v_right_mps: float
    v_left_mps: float
    fallback: bool = False
    """True when the controller used its fallback instead of its normal answer."""
    reason: str = ""
    """Why a fallback was used, or which candidate won."""
    planned_wheels_mps: np.ndarray | None = None
    """(H, 2) planned right/left wheel speeds, when the controller plans."""
    planned_poses: np.ndarray | None = None
    """(H, 3) predicted poses after each planned step."""
    cost: float = float("nan")
    info: dict = field(default_factory=dict)
    forecasts: tuple | None = None
    """The obstacle forecasts the decision was made with, one per moving obstacle the
    controller tracks (objects with the fields of :class:`ObstacleForecast`), when the
    controller estimates them with :class:`casadi_gpc.estimation.tracking.TrackBank`; a
    :class:`~casadi_gpc.safety.Shield` then checks against these instead of running a second
    bank. None: the controller does not say."""
    alternatives: tuple = ()
    """Other (H, 2) wheel-speed plans the controller would accept, best first (the planner's
    other solved candidates): what a :class:`~casadi_gpc.safety.Shield` tries before its own
    manoeuvres when the decision fails the check."""


class Policy(Protocol):
    """What the simulator, the evaluator and the benchmark talk to."""

    sample_time_s: float

    def reset(self) -> None: ...

    def decide(self, observation: Observation) -> ControlDecision: ...


class ProtocolError(TypeError):
    """A controller that does not answer the :class:`Policy` protocol at run time: its
    ``decide()`` returned something other than a :class:`ControlDecision`."""


def policy_class_name(policy) -> str:
    """The dotted name of ``policy``'s class, as a :class:`ProtocolError` names it; a wrapper that
    holds the controller as ``wrapped`` (the command line's guard of a ``MODULE:CLASS``) names the
    class it wraps, the one its user wrote."""
    cls = type(getattr(policy, "wrapped", policy))
    return f"{cls.__module__}.{cls.__qualname__}"


def checked_decision(decision, policy, numbers: bool = False) -> ControlDecision:
    """``decision``, which ``policy.decide()`` returned, if it is a :class:`ControlDecision`;
    else a :class:`ProtocolError` naming the class (a tuple failed later, as an
    ``AttributeError`` deep in the simulator). With ``numbers`` (a user's class), its wheel speeds
    must be real numbers too, NaN included (a command the robot brakes for and counts): a word or
    an array failed deep in the simulator with a traceback, and None was braked for in silence."""
    if not isinstance(decision, ControlDecision):
        raise ProtocolError(f"{policy_class_name(policy)}.decide() returned a {type(decision).__name__}, not "
                            f"a casadi_gpc.ControlDecision (the Policy protocol)")
    for name in ("v_right_mps", "v_left_mps") if numbers else ():
        v = getattr(decision, name)
        if isinstance(v, bool) or not isinstance(v, Real):
            import reprlib
            raise ProtocolError(f"{policy_class_name(policy)}.decide() returned a ControlDecision whose {name} "
                                f"is {' '.join(reprlib.repr(v).split())} (a {type(v).__name__}), not a number of m/s "
                                f"(the Policy protocol)")
    return decision
