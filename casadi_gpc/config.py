"""Planner settings and the two presets, ``paper`` and ``improved``.

The paper fixes H = 6 and the weights but not the sample time, the units or P; each
field's docstring says where its value comes from. ``docs/model.md`` has the formulas
and the measurements behind the choices.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

__all__ = ["PlannerConfig", "PRESETS", "preset", "DEFAULT_PRESET"]


@dataclass(frozen=True)
class PlannerConfig:
    """Everything that defines the GPC problem (not the robot, which is a scenario's)."""

    name: str
    sample_time_s: float
    """T. Not in the paper; settled by measurement (docs/model.md)."""
    horizon: int = 6
    """H, prediction = control horizon (paper: 6)."""
    xi_moving: float = 3.0
    """xi1, weight of 1/(P dist^2) for moving obstacles (paper: 3)."""
    xi_static: float = 3.0
    """xi2, the same for static obstacles (paper: 3)."""
    lambda1: float = 63.0
    """Weight of dVr^2 + dVl^2, wheel-speed increments in m/s (paper: 63)."""
    lambda2: float = 10.0
    """Weight of (Vr - Vl)^2 in (m/s)^2 (paper: 10)."""
    tracking_weight: float = 1.0
    """Weight of the squared position error in m^2 (paper: 1)."""
    heading_weight: float = 1.0
    """Weight of the squared, wrapped heading error in rad^2 (paper: 1)."""
    uncertainty_scale_m: float = 0.5
    """P = 1 + (var_x + var_y) / uncertainty_scale_m^2: an obstacle whose predicted position
    has this RMS uncertainty counts half."""
    clearance_softening_m: float = 0.02
    """The clearance d enters as (d + sqrt(d^2 + e^2)) / 2, a smooth positive stand-in for
    d that keeps 1/d^2 finite (and growing) when the discs touch."""
    influence_m: float | None = None
    """If set, the obstacle term is xi/P (1/d - 1/d0)^2 for d < d0 and zero beyond, so
    obstacles far away leave the path alone. None: the paper's xi/(P d^2) everywhere."""
    clearance_margin_m: float | None = None
    """If set, a soft constraint d >= margin + k sigma enforced by a steep penalty."""
    clearance_penalty: float = 1e4
    """Weight of the squared violation of the clearance margin."""
    margin_smoothing_m: float | None = None
    """If set, the margin's violation ``max(m - d, 0)`` enters as the smooth
    ``(v + sqrt(v^2 + e^2)) / 2`` with this ``e``: the exact form's curvature jumps from 0
    to twice the penalty at the margin, and the SQP's Newton steps kept overshooting it
    (warm starts in crowds: 14 iterations median, 8 with e = 0.05 m, on the same recorded
    problems). It adds e^2/4 times the penalty right at the margin and fades within ~2 e
    outside it: the robot keeps a few cm more."""
    uncertainty_sigmas: float = 2.0
    """k: how many predicted position standard deviations inflate the margin."""
    walls_margin_m: float | None = None
    """Near walls, the clearance margin in place of :attr:`clearance_margin_m` (for every
    obstacle, walls included), with :attr:`walls_sigmas` in place of
    :attr:`uncertainty_sigmas`, at the ticks where a wall segment is within the robot's reach
    (:func:`casadi_gpc.geometry.walls_reach_m`, the check's own rule; counted
    ``walls_margin_ticks``). Where walls bound the room, a person walking down the middle of
    a 2.5 m corridor leaves no place beside them that keeps the open-space margin, and the
    planner backed away before people for metres (docs/buildings.md). The NLP of a map with
    walls then takes the margin and its sigmas as parameters (the same numbers elsewhere).
    None: one margin everywhere."""
    walls_sigmas: float | None = None
    """With :attr:`walls_margin_m`: the standard deviations that inflate the margin near walls."""
    walls_directional_sigma: bool = False
    """With :attr:`walls_margin_m`: near walls, the margin from each mover is inflated by its
    forecast's deviation along the line from it to the robot, sqrt(u' C u), not by its worst
    (the covariance's largest axis). A walker's forecast is much surer across their way than
    along it: in the corridor suite the deviation across is a third of the one along at the
    horizon's end (0.12 against 0.36 m, medians), so the worst made a place beside a person
    walking down a corridor as dear as one in front of them. The check layer keeps the worst.
    Off in both presets: rejected by a rule on unseen cases (0 -> 2 collisions with the robot
    approaching), and over that set and one more, 1 500 episodes, collisions 27 -> 25 (the
    suites' turnover), with the robot approaching 1 -> 4, decisions slower
    (docs/data/buildings/walls_directional/rule.md)."""
    walls_sigma_cap_m: float | None = None
    """With :attr:`walls_margin_m`: near walls, the forecast's standard deviation that inflates
    the margin is taken at most this (m); the obstacle term's uncertainty is not changed.
    Across a corridor a person strays no further than the walls let them, which the filter's
    isotropic forecast does not know: its deviation grows to about 0.36 m at the horizon's end,
    and a place at the wall beside a person walking down the middle kept the margin for the
    first steps and lost it at the last, so the planner backed away from where the forecast is
    unsure of the person 6 s ahead. None: the forecast's own (both presets: 0.10 m was
    rejected by a rule on unseen cases, docs/data/buildings/walls_sigma_cap/rule.md: 754 ->
    761 goals, 6 -> 8 collisions)."""
    beyond_horizon_s: tuple[float, ...] = ()
    """Instants after the horizon's end (s) at which the robot, standing where the plan leaves
    it, must still keep the clearance margin from each mover carried on straight at the
    velocity of its forecast's last step (the margin's penalty, the sigma of the forecast's
    last step). A plan that ends standing in a mover's way pays for it although the contact
    lies beyond the horizon: the passive-safety idea (end where staying put is safe), written
    into the cost. Empty: the horizon alone (the paper)."""
    max_lead_m: float | None = None
    """If set, the reference point never runs more than this far ahead of the robot's
    projection on the path (it waits while the robot yields). None: the paper's clock."""
    max_moving: int = 3
    """Moving-obstacle slots of the NLP (unused slots are switched off). With more movers,
    the most relevant fill them (:mod:`casadi_gpc.problem.selection`)."""
    crowd_moving: int | None = None
    """Moving-obstacle slots of a second NLP, solved at the ticks where the controller tracks
    more movers than :attr:`max_moving` slots hold; the first NLP at every other tick, so a
    scene with no more movers than ``max_moving`` is planned as without it (counted:
    ``crowd_ticks``; :mod:`casadi_gpc.planner.tiers`). None, or not above ``max_moving``: one
    NLP."""
    relevance_range_m: float = 2.5
    """A mover left out of the slots is counted (``left_out``) when its predicted clearance
    to the robot's predicted path is under this (the obstacle term's 1.5 m reach of the
    ``improved`` preset plus 1 m of room for the plan to change)."""
    goal_weight: float = 1.0
    """Factor on the tracking weight of the desired poses at the end of the path. The
    paper's 1 lets an obstacle standing near the goal hold the robot off it: under
    ``improved``, a walker standing 1 m from the goal kept the robot 0.4 m away, outside the
    goal's 0.3 m, until the time limit; with 10, two walkers standing 1 m either side of the
    goal still did (their obstacle terms outweighed 40 times the squared offset); 30 brings
    it within 0.15 m (docs/model.md)."""
    max_static: int = 3
    """Static-obstacle slots of the NLP."""
    max_walls: int = 0
    """Wall-segment slots of the NLP: the robot's clearance to each segment, penalised as the
    paper penalises a static obstacle, with the same margin. 0 (the presets): the NLP knows
    no walls, and is the one it always was; the command line gives a run whose scenarios
    have walls :data:`WALL_SLOTS` (the nearest segments to the predicted path fill them)."""
    multistart_range_m: float = 3.0
    """Extra range, beyond the robot's reach in one horizon, within which an obstacle makes
    the GPC solve from several initial guesses."""
    candidates: str = "persistent"
    """``persistent``: the solutions found are kept alive from tick to tick and warm-started,
    the fixed guesses solved again only when an obstacle comes near, when every candidate was
    lost, or every ``multistart_period_s`` (:mod:`casadi_gpc.planner.candidates`); ``multistart``:
    every fixed guess and the previous plan at every tick near obstacles (the reference)."""
    multistart_period_s: float = 3.0
    """Longest time between two full multi-starts while obstacles are near (persistent
    candidates)."""
    surprise_ratio: float | None = 0.2
    """Persistent candidates: when the best warm-started candidate costs more than this
    fraction above the last tick's best, the fixed guesses are solved as well in the same
    tick (a minimum may have opened that no kept candidate is in). None: never."""
    relevance_memory_s: float = 3.0
    """Persistent candidates: an obstacle that mattered within this long (rounded to whole
    samples, at least one) is not new when it matters again, so it does not make a full
    multi-start due (:mod:`casadi_gpc.planner.candidates`)."""
    prune_ratio: float | None = 0.25
    """Persistent candidates: a candidate dearer than the best by more than this fraction
    is let go (None: every distinct one is kept)."""
    swerve_turn_rate_rad_s: float = 0.5
    """Turn rate of the swerve-left / swerve-right initial guesses."""
    guesses: tuple[str, ...] = ("swerve_right", "swerve_left", "straight", "detour_right", "detour_left")
    """The fixed initial guesses of the multi-start, by name (:data:`casadi_gpc.planner.guesses.TIE_ORDER`
    gives their tie-break order whatever the order here)."""
    solver: str = "ipopt"
    """NLP solver backend of the controller (``casadi_gpc.solvers.SOLVER_NAMES``; ``ipopt`` is
    ``ipopt-warm``). The presets use the one ``gpcnav bench`` measured fastest among those
    that reach IPOPT's cost (docs/solvers.md)."""
    solve_lanes: int = 2
    """Starts of one tick solved at once, in this many threads (:mod:`casadi_gpc.planner.lanes`);
    the answers are the same for any number. Solvers that cannot run in threads (IPOPT,
    Powell, the uncompiled SQP) use one."""
    walls_forecast: bool = False
    """In a scene whose map has walls, each walker measured at the last 9 samples is also
    forecast by the network learned from walkers in buildings, handed to the planner and its
    check as a second mover beside the filter's forecast
    (:mod:`casadi_gpc.estimation.walls_forecast`; only at the 0.5 s and 12 steps it was trained
    at). Adopted for ``improved`` by a rule on unseen cases: among walkers blind to the robot no
    collision in 600 episodes against 5, navground's corridor 82 -> 77 goals of 99
    (docs/data/pedestrians/learned_forecast/union/rule.md)."""
    forecast: str = "turn"
    """How the movers' filters forecast the horizon: ``turn``, the paper's model (the
    estimated turn increment kept); ``straight``, the same filter's estimate at constant
    speed and heading (:func:`casadi_gpc.estimation.obstacle_model.straightened`). Real people do not keep
    a turn: on the UCY recordings the straight forecast is 15-22 % closer (ADE), and behind
    the check the ``improved`` GPC was hit in fewer cases (docs/pedestrians.md, "The planner
    among real crowds"). The planner's only: the shipped networks keep the forecast they were
    trained with (the turning one)."""
    cold_starts: int | None = None
    """Persistent candidates: at most this many of the fixed guesses are solved at one tick.
    A full multi-start that is due solves the first ones and leaves the rest for the next
    ticks, in tie order (a cycle; a multi-start due while one is under way joins it), while
    every kept candidate is warm-started at every tick as before. None: all of them at once
    (:meth:`casadi_gpc.planner.gpc.GPCController.plan_persistent`). In dense crowds a newcomer
    matters at nearly every tick: six cold starts at half the ticks made the decision's
    median 11-13 ms among the UCY recordings, where a cold start costs ~4 ms
    (docs/pedestrians.md)."""
    cold_start_gap: int = 0
    """With :attr:`cold_starts`: ticks without a queued guess after each tick that solved one,
    while a cycle runs (a cycle falling due, or a surprise, solves its guess at once). 0:
    every tick. Among 30 walkers a cycle runs at nearly every tick, and its cold start is the
    decision's median (docs/pedestrians.md)."""
    time_budget_s: float | None = None
    """Wall time one control step may spend solving; an answer later than this is not used
    and the step falls back (counted), and a start that the controller's recent solves say
    would end later is not begun. None: 0.8 of the sample time
    (:data:`casadi_gpc.planner.gpc.SOLVE_SHARE`: the rest is the check's)."""

    def __post_init__(self):
        self._check_numbers()
        if self.forecast not in FORECASTS:
            raise ValueError(f"forecast must be one of {', '.join(FORECASTS)}, got {self.forecast!r}")
        if self.candidates not in CANDIDATES:
            raise ValueError(f"candidates must be one of {', '.join(CANDIDATES)}, got {self.candidates!r}")
        if self.cold_starts is not None and self.cold_starts < 1:
            raise ValueError(f"cold_starts must be at least 1 (or None), got {self.cold_starts}")
        if self.crowd_moving is not None and not (isinstance(self.crowd_moving, int) and self.crowd_moving >= 1):
            raise ValueError(f"crowd_moving must be a whole number of at least 1 (or None), got {self.crowd_moving!r}")
        if any(not (math.isfinite(t) and t > 0) for t in self.beyond_horizon_s):
            raise ValueError(f"beyond_horizon_s must hold times above 0 s, got {self.beyond_horizon_s!r}")
        if (self.walls_margin_m is None) != (self.walls_sigmas is None):
            raise ValueError("walls_margin_m and walls_sigmas go together (both set, or neither)")
        if self.walls_margin_m is not None:
            if self.clearance_margin_m is None:
                raise ValueError("walls_margin_m replaces clearance_margin_m near walls: set that too")
            for name in ("walls_margin_m", "walls_sigmas"):
                v = getattr(self, name)
                if not (math.isfinite(v) and v >= 0):
                    raise ValueError(f"{name} must be finite and not negative, got {v}")
        if self.walls_directional_sigma and self.walls_margin_m is None:
            raise ValueError("walls_directional_sigma applies where the margin near walls does: set walls_margin_m too")
        if self.walls_directional_sigma and self.walls_sigma_cap_m is not None:
            raise ValueError("walls_directional_sigma and walls_sigma_cap_m are two ways to shrink the same deviation: "
                             "set one")
        if self.walls_sigma_cap_m is not None:
            if self.walls_margin_m is None:
                raise ValueError("walls_sigma_cap_m applies where the margin near walls does: set walls_margin_m too")
            if not (math.isfinite(self.walls_sigma_cap_m) and self.walls_sigma_cap_m >= 0):
                raise ValueError(f"walls_sigma_cap_m must be finite and not negative, got {self.walls_sigma_cap_m}")
        if not (isinstance(self.cold_start_gap, int) and self.cold_start_gap >= 0):
            raise ValueError(f"cold_start_gap must be a whole number, not negative, got {self.cold_start_gap!r}")

    def _check_numbers(self) -> None:
        """Refuse, naming the setting, a number no planner can be built or run with (they
        crashed later, inside CasADi or IPOPT, or ran with a negative weight)."""
        if not (isinstance(self.horizon, int) and not isinstance(self.horizon, bool) and self.horizon >= 1):
            raise ValueError(f"horizon must be a whole number of at least 1, got {self.horizon!r}")
        if not (math.isfinite(self.sample_time_s) and self.sample_time_s > 0):
            raise ValueError(f"sample_time_s must be finite and above 0 s, got {self.sample_time_s!r}")
        for name in _WEIGHTS:
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be finite and not negative (a weight), got {v!r}")
        for name in _NOT_NEGATIVE:
            v = getattr(self, name)
            if v is not None and not v >= 0:  # NaN fails too
                raise ValueError(f"{name} must not be negative, got {v!r}")
        for name in _POSITIVE:
            v = getattr(self, name)
            if v is not None and not v > 0:
                raise ValueError(f"{name} must be above 0, got {v!r}")
        for name in _COUNTS:
            v = getattr(self, name)
            low = 1 if name == "solve_lanes" else 0
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= low):
                raise ValueError(f"{name} must be a whole number of at least {low}, got {v!r}")

    def for_walls(self, walls: bool) -> "PlannerConfig":
        """These settings for a map with walls (``walls``): the NLP's wall slots
        (:data:`WALL_SLOTS`) unless it has some; without walls, unchanged (the NLP it always
        had)."""
        return self.with_overrides(max_walls=WALL_SLOTS) if walls and not self.max_walls else self

    def for_movers(self, n: int) -> "PlannerConfig":
        """These settings for scenes of at most ``n`` movers: without the crowd NLP
        (:attr:`crowd_moving`) where ``n`` fits the first NLP's slots, which is then all the
        planner ever solves (the crowd NLP is built with the controller: about a second the
        first time in a process, 0.3 s after, docs/solvers.md)."""
        return replace(self, crowd_moving=None) if self.crowd_moving is not None and n <= self.max_moving else self

    def with_overrides(self, **changes) -> "PlannerConfig":
        return replace(self, **{k: v for k, v in changes.items() if v is not None})

    def to_dict(self) -> dict:
        return asdict(self)


FORECASTS = ("turn", "straight")
"""The movers' forecast models (:attr:`PlannerConfig.forecast`)."""
CANDIDATES = ("persistent", "multistart")
"""How the planner keeps its starts from tick to tick (:attr:`PlannerConfig.candidates`)."""
_WEIGHTS = ("xi_moving", "xi_static", "lambda1", "lambda2", "tracking_weight", "heading_weight", "clearance_penalty",
            "goal_weight")
"""The cost's weights: finite, not negative (a negative one rewards what the cost penalises)."""
_NOT_NEGATIVE = ("uncertainty_scale_m", "clearance_softening_m", "clearance_margin_m", "margin_smoothing_m",
                 "uncertainty_sigmas", "max_lead_m", "relevance_range_m", "multistart_range_m", "relevance_memory_s",
                 "surprise_ratio", "prune_ratio", "swerve_turn_rate_rad_s")
"""Lengths, times and ratios that may be 0 (or None where the setting allows it), or
infinite where that means "no limit", but not negative or NaN."""
_POSITIVE = ("influence_m", "multistart_period_s", "time_budget_s")
"""Settings that must be above 0 where they are set."""
_COUNTS = ("max_moving", "max_static", "max_walls", "solve_lanes")
"""Whole numbers: slots (0 or more) and the solve lanes (1 or more)."""

WALL_SLOTS = 6
"""The wall-segment slots a planner gets where the map has walls (``max_walls``): a corner
of two corridors is four segments, a doorway two, with two to spare."""


PRESETS: dict[str, PlannerConfig] = {
    # solver: measured by `gpcnav bench --preset paper|improved` (docs/solvers.md)
    # a full multi-start every 4 steps at most: 3 s would be every other step at T = 1.5 s
    # at T = 1.5 s the cost jumps from step to step as an obstacle nears: a surprise is no sign
    # of a new minimum there (measured: the same plans on Fig. 7 with one solve a step fewer)
    # relevance memory of one sample: at T = 1.5 s a walker moves 2 m between samples, so one
    # that comes back two samples later is a new encounter (measured, 20 crowds of 10 under
    # paper with 3 s: success 55 -> 40 %, fallbacks 59 -> 72)
    "paper": PlannerConfig(name="paper", sample_time_s=1.5, solver="sqpmethod-daqp+fatrop", multistart_period_s=6.0,
                           surprise_ratio=None, relevance_memory_s=1.5),
    "improved": PlannerConfig(
        name="improved",
        sample_time_s=0.5,
        horizon=12,
        tracking_weight=4.0,
        influence_m=1.5,
        clearance_margin_m=0.15,
        max_lead_m=0.5,
        solver="sqpmethod-daqp+fatrop",
        # 10 mover slots: with 6, the movers left out of a converging crowd are the ones the
        # plan runs into (with the walkers' true futures as its forecasts the GPC still
        # collided there); 10 took circle crossings among 10 walkers from 5 collisions in 600
        # to none (docs/crowds.md, "The cost of a slot")
        max_moving=10,
        # among 20 to 30 walkers more than 10 matter at once: 16 slots at those ticks took
        # square crossings among 30 walkers from 10 collisions in 40 to 2 (development seed 4;
        # docs/pedestrians.md, "Slots for a crowd")
        crowd_moving=16,
        margin_smoothing_m=0.05,
        # near walls 0.05 m + 1 sigma for 0.15 m + 2 sigma: in navground's corridor the planner
        # was pushed back by people walking at it, no place beside them keeping the open margin;
        # with its check's (gpcnav.controllers._gpc_check) adopted by a rule on unseen cases
        # (docs/data/buildings/walls_margin/rule3.md: 725 -> 753 goals, 19 -> 16 collisions)
        walls_margin_m=0.05,
        walls_sigmas=1.0,
        goal_weight=30.0,
        guesses=("swerve_right", "swerve_left", "straight", "detour_right", "detour_left", "brake"),
        # real people do not keep a turn (docs/pedestrians.md, "The planner among real crowds")
        forecast="straight",
        # near walls, each walker's learned forecast beside the filter's (a rule on unseen cases:
        # docs/data/pedestrians/learned_forecast/union/rule.md)
        walls_forecast=True,
        # one cold start a tick: six at once made the median decision 11-13 ms among the
        # UCY recordings (docs/pedestrians.md, "The planner among real crowds")
        cold_starts=1,
        # cold_start_gap stays 0: one guess every other tick measured mixed on seed 1 (fewer
        # collisions among 30 walkers and round the corner, more among 20 and among the
        # recorded people; docs/pedestrians.md, "A cold start every other tick")
    ),
}
DEFAULT_PRESET = "improved"


def preset(name: str) -> PlannerConfig:
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown preset {name!r} (choose from {', '.join(PRESETS)})") from None
