"""GPC labels for situations: the planner's first control, its plan, cost and status.

Each situation is solved the way the planner solves a fresh problem: from the planner's fixed
initial guesses (:data:`GUESS_NAMES`: swerve right, swerve left, straight, and the detours
where the planner has them) with the planner's own tie-break
(:meth:`casadi_gpc.planner.gpc.GPCController.plan`), on the NLP parameters the planner would pack.
The labelling solver is the one measured fastest for these cold multi-starts
(:data:`LABEL_SOLVERS`, else ``casadi_gpc.solvers.FASTEST_SOLVER``); where
none of its starts converges, IPOPT at a tight tolerance solves the situation again
(:data:`FALLBACK_SOLVER`; 0 % of ``paper`` situations, ~5-9 % of ``improved`` ones, nearly
all with an obstacle already inside the clearance margin). Only converged solutions become
samples; the others are counted.

Mirror samples: a situation reflected about the reference's tangent has the mirrored
features (:func:`~nn_export.runtime.features.mirror_features`) and, because the GPC problem is
mirror-equivariant, the label with the wheels swapped. :meth:`Labeller.mirror_check`
solves the mirrored situation for real and returns the largest difference, which the
dataset writer records for a share of the situations as a check of the labels. Measured:
under ``paper`` every checked answer agrees to 1e-8 m/s; under ``improved`` about 1-2 %
of sampled situations have the two sides' multi-starts reach different optima (never a
tie), and the writer then keeps the cheaper answer for both. (An exact tie between a left
and a right swerve is the one place where the answer cannot be equivariant: the tie-break
picks the right swerve both times.)

Near ties (``tie_margin``, :mod:`nn_export.training.ties`): with a margin set, where the
NLP holds one obstacle and the starts found both a pass on the right and a pass on the left,
the label is the pass on the right unless it costs more than ``tie_margin`` (relative) above
the pass on the left; the label keeps the other side's answer (``alternative``) so that the
mirror sample is labelled by the same rule (:meth:`Label.mirrored`). ``None`` (the default)
is the planner's own choice, bit for bit.

This module needs CasADi (it runs the planner); the features it uses are numpy only.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.problem.cost import layout_of, to_world
from casadi_gpc.robot import RobotParams
from casadi_gpc.geometry import walls_reach_m
from casadi_gpc.problem.selection import near_walls, pack_selection, select_obstacles, select_walls

from ..runtime.features import compute_features, mirror_features
from ..runtime.layouts import FeatureLayout
from ..runtime.situation import Situation
from .ties import LEFT, RIGHT, choose, passing_side

__all__ = ["LABEL_NAMES", "GUESS_NAMES", "MIRROR_GUESS_ORDER", "Label", "Labeller", "fastest_solver", "label_solver",
           "available_solvers", "mirror_label", "mirror_guess", "MOVING_RUNGS", "STATIC_RUNGS", "fitted_slots"]

LABEL_NAMES = ("v_right_mps", "v_left_mps")
"""The network's outputs: the wheel speeds to apply over the next interval."""
try:  # the planner's initial guesses, in its tie-break order
    from casadi_gpc.planner.guesses import TIE_ORDER as GUESS_NAMES
except ImportError:  # pragma: no cover - older planner
    GUESS_NAMES = ("swerve_right", "swerve_left", "straight")
LABEL_TOLERANCE = 1e-12
"""IPOPT's tolerance for labels (the planner's closed loop uses 1e-9)."""
SAME_OPTIMUM_MPS = 1e-4
"""Starts whose increments differ by less than this (and whose costs tie) found one optimum."""
FALLBACK_SOLVER = "ipopt-warm"
"""Solves the situations where no initial guess converged with the labelling solver."""
MOVING_RUNGS = (1, 2, 4, 6)
STATIC_RUNGS = (0, 1)
"""The NLP sizes (obstacle slots) the labeller solves on below the planner's own
(:func:`fitted_slots`): few, so that few variants are compiled and held."""


def fitted_slots(n_moving: int, n_static: int, config: PlannerConfig) -> tuple[int, int]:
    """The slots ``(moving, static)`` of the smallest NLP that holds ``n_moving`` movers and
    ``n_static`` static obstacles: each count rounded up to a rung (:data:`MOVING_RUNGS`, at
    least one moving slot; :data:`STATIC_RUNGS`), else the config's own slots (the full NLP)."""
    if not (0 <= n_moving <= config.max_moving and 0 <= n_static <= config.max_static):
        raise ValueError(f"{n_moving} moving and {n_static} static obstacles do not fit the planner's NLP "
                         f"({config.max_moving} and {config.max_static} slots)")
    m = next((r for r in MOVING_RUNGS if r >= max(1, n_moving)), config.max_moving)
    s = next((r for r in STATIC_RUNGS if r >= n_static), config.max_static)
    return min(m, config.max_moving), min(s, config.max_static)


@dataclass(frozen=True)
class Label:
    """The GPC's answer for one situation."""

    converged: bool
    wheels_mps: np.ndarray
    """(2,) right and left wheel speeds of the first step (the label)."""
    plan_wheels_mps: np.ndarray
    """(H, 2) the whole planned wheel-speed sequence."""
    cost: float
    status: str
    """The solver's status of the winning candidate (or the first failure)."""
    guess: str
    """Which initial guess won."""
    iterations: int
    candidate_costs: np.ndarray
    """Cost from each guess in :data:`GUESS_NAMES` order, NaN where it did not converge."""
    solve_time_s: float
    solves: int = 0
    solver: str = ""
    """The solver that produced the answer (the fallback solver's name if it had to step in)."""
    side: int = 0
    """The side it passes the obstacle on (+1 right, -1 left; 0: not classified, see
    :mod:`nn_export.training.ties`)."""
    alternative: "Label | None" = None
    """The best answer on the other side, where the starts found both and a tie margin is set."""
    tie_margin: float | None = None
    """The near-tie margin the answer was chosen with (None: the planner's own choice)."""

    @property
    def n_converged(self) -> int:
        return int(np.count_nonzero(np.isfinite(self.candidate_costs)))

    def mirrored(self) -> "Label":
        """The answer for the mirrored situation: this one with wheels, guesses and side
        swapped, or, where a near-tie margin chose between two sides, the same rule applied
        to the mirrored candidates (the mirror's pass on the right is this one's pass on
        the left)."""
        own = self._reflected()
        if self.alternative is None:
            return own
        alt = self.alternative._reflected()
        right, left = (own, alt) if own.side == RIGHT else (alt, own)
        pick = choose(right, left, self.tie_margin or 0.0)
        return replace(pick, alternative=alt if pick is own else own, tie_margin=self.tie_margin)

    def _reflected(self) -> "Label":
        return replace(self, wheels_mps=mirror_label(self.wheels_mps),
                       plan_wheels_mps=mirror_label(self.plan_wheels_mps), guess=mirror_guess(self.guess),
                       candidate_costs=self.candidate_costs[MIRROR_GUESS_ORDER], side=-self.side, alternative=None)


def mirror_guess(name: str) -> str:
    """The guess that is the mirror image of ``name`` (right and left swapped)."""
    if name.endswith("_right"):
        return name[: -len("_right")] + "_left"
    if name.endswith("_left"):
        return name[: -len("_left")] + "_right"
    return name


MIRROR_GUESS_ORDER = np.array([GUESS_NAMES.index(mirror_guess(g)) for g in GUESS_NAMES])
"""Index map: ``candidate_costs[MIRROR_GUESS_ORDER]`` are the mirror situation's costs."""


def mirror_label(label_wheels: np.ndarray) -> np.ndarray:
    """Wheel speeds of the mirrored situation: right and left swapped (last axis)."""
    return np.asarray(label_wheels)[..., ::-1]


def available_solvers() -> tuple[str, ...]:
    """Solver names the planner accepts (``casadi_gpc.solvers`` once it exists)."""
    try:
        from casadi_gpc import solvers
    except ImportError:
        return ("ipopt",)
    names = tuple(getattr(solvers, "SOLVER_NAMES", ()) or ()) + tuple(getattr(solvers, "ALIASES", {}) or {})
    return names or ("ipopt",)


LABEL_SOLVERS = {"paper": "sqpmethod-daqp", "improved": "sqpmethod-daqp+fatrop"}
"""The labelling solver per preset, measured on sampled situations (every solve of a label
is a cold start from a fixed guess, where the closed loop mostly warm-starts): under
``paper`` the plain SQP labels in 2.1 ms CPU per situation against 4.0 ms for the hybrid
(whose cold starts are fatrop's), both mirror-symmetric to 1e-10; under ``improved`` the
hybrid costs 10 % more but its answers were mirror-symmetric to 1e-13 on 50 situations where
the plain SQP's missed 1e-6 on 4."""


def label_solver(config: PlannerConfig) -> str:
    """The solver that labels ``config``'s situations (:data:`LABEL_SOLVERS`, else the
    planner's fastest)."""
    name = LABEL_SOLVERS.get(config.name)
    return name if name is not None and name in available_solvers() else fastest_solver()


def fastest_solver() -> str:
    """The fastest NLP solver the planner offers (``casadi_gpc.solvers.FASTEST_SOLVER``),
    else the planner's default."""
    try:
        from casadi_gpc import solvers
    except ImportError:
        return PlannerConfig.solver
    return str(getattr(solvers, "FASTEST_SOLVER", PlannerConfig.solver))


def _merge_duplicates(best, candidates) -> np.ndarray:
    """The winner's increments, averaged with every other start that reached the same
    optimum (same cost to the planner's tie tolerance and the same increments to
    :data:`SAME_OPTIMUM_MPS`).

    Starts that reach one optimum agree only to the solver's tolerance (~1e-5 m/s for the
    SQP), and the tie-break's pick among them is not mirror-symmetric: the mirrored
    situation's right-swerve start is the original's left-swerve start. The average over
    all of them is (their set is the mirror image of the other side's), which makes the
    labels mirror-symmetric to ~1e-10 instead of ~1e-5. Different optima (a left and a
    right pass) are never averaged: those stay with the planner's tie-break.
    """
    from casadi_gpc.planner.multistart import TIE_RELATIVE
    u0 = np.asarray(best.u, dtype=float)
    same = [np.asarray(c.u, dtype=float) for c in candidates
            if c.success and abs(c.cost - best.cost) <= TIE_RELATIVE * abs(best.cost) + 1e-12
            and np.max(np.abs(np.asarray(c.u) - u0)) <= SAME_OPTIMUM_MPS]
    return np.mean(same, axis=0) if len(same) > 1 else u0


class Labeller:
    """Labels situations with the GPC of ``config`` (the solvers are built once).

    ``solver``: the planner's solver name; ``None`` takes :func:`label_solver`.
    ``fallback_solver``: when no initial guess converges with ``solver``, the situation is
    solved again with this one (built on first need; ``None``: never). The hardest
    situations (an obstacle already inside the clearance margin) are where the SQP fails
    most, and dropping them would leave the network without examples exactly there.

    NLP size (``fit_slots``): the obstacles are chosen as the planner chooses them, with
    ``config``'s slots (:func:`casadi_gpc.problem.selection.select_obstacles`), and the situation is
    then solved on the smallest NLP whose slots hold the ones chosen (:func:`fitted_slots`;
    each size built on first need, counted in ``counters``: ``fitted_nlp`` / ``full_nlp``
    and ``nlp_<moving>x<static>``). An empty slot is parked far away with its terms
    multiplied by an "on" flag of 0 (:mod:`casadi_gpc.problem.cost`): it adds exact zeros to the
    cost and its derivatives, so the answer is the full NLP's bit for bit (measured: max
    difference 0.0 on 300 ``paper``-layout, 60 ``multi`` and 40 ``set`` ``improved``
    situations), only cheaper. The ``paper`` layout's situations (one mover at most) are
    solved on 1 + 0 slots instead of the 6 + 3 ``improved`` had then (10 + 3 now): 8.7 ms CPU
    a situation instead of 11.2 (one lane, 300 situations), and ``gpcnav dataset --preset
    improved --samples 4000 --workers 2`` on 2 cores (interleaved, nothing else running) at 402
    and 416 samples/s against 333 and 342 (about 1.2x; the shards' CPU time 19.6 and 18.8 s
    against 23.5 and 23.0 s), the shards identical. ``fit_slots=False`` always solves on the
    full NLP. :meth:`parameters` is the full NLP's vector either way.
    """

    def __init__(self, config: PlannerConfig, robot: RobotParams | None = None, solver: str | None = None,
                 fallback_solver: str | None = FALLBACK_SOLVER, tie_margin: float | None = None,
                 fit_slots: bool = True):
        if tie_margin is not None and not (0.0 <= tie_margin < 1.0 and np.isfinite(tie_margin)):
            raise ValueError(f"tie_margin must be in [0, 1), got {tie_margin}")
        self.tie_margin = tie_margin
        self.solver = solver or label_solver(config)
        for name in (self.solver, fallback_solver):
            if name is not None and name not in available_solvers():
                raise ValueError(f"unknown solver {name!r} (the planner offers {', '.join(available_solvers())})")
        self.config = config if config.solver == self.solver else config.with_overrides(solver=self.solver)
        self.robot = robot or RobotParams()
        self.fit_slots = bool(fit_slots)
        self.full_slots = (config.max_moving, config.max_static)
        self.layout = layout_of(config, self.robot)
        self._walls: list = []
        """The wall segments in the slots of the situation being labelled."""
        """The full NLP's parameter layout (:meth:`parameters`)."""
        self._controllers: dict = {}
        """``(solver, moving slots, static slots)`` -> controller, built on first need."""
        same = fallback_solver is None or fallback_solver == self.solver or (
            fallback_solver.startswith("ipopt") and self.solver.startswith("ipopt"))
        self.fallback_solver = None if same else fallback_solver
        self.counters = {"situations": 0, "not_converged": 0, "solves": 0, "fallback_used": 0,
                         "fallback_converged": 0, "fitted_nlp": 0, "full_nlp": 0}
        if not self.fit_slots:
            self.prepare()

    def _controller(self, solver: str, slots: tuple[int, int] | None = None):
        """The controller of ``solver`` on the NLP with ``slots`` (default: the full one), built once."""
        slots = self.full_slots if slots is None else tuple(slots)
        key = (solver, *slots)
        if key not in self._controllers:
            from casadi_gpc.planner.gpc import GPCController
            # labels are solved tighter than the closed loop needs: when several initial guesses
            # reach the same optimum, the tie-break's pick must not show through the solver's
            # tolerance (at IPOPT's 1e-9 the first control differs by up to ~5e-6 m/s between
            # starts; at 1e-12 by ~1e-7). The SQP's own tolerance already gives ~1e-9.
            kw = {"ipopt_options": {"ipopt.tol": LABEL_TOLERANCE}} if solver.startswith("ipopt") else {}
            # no crowd NLP: a situation fills at most the config's slots
            cfg = replace(self.config, solver=solver, max_moving=slots[0], max_static=slots[1], crowd_moving=None)
            self._controllers[key] = GPCController(cfg, self.robot, **kw)
        return self._controllers[key]

    @property
    def controller(self):
        """The labelling solver's controller on the full NLP (built on first need)."""
        return self._controller(self.solver)

    def slots_for(self, n_moving: int, n_static: int) -> tuple[int, int]:
        """The slots of the NLP that solves a situation whose selection holds ``n_moving``
        movers and ``n_static`` static obstacles (the full NLP's without ``fit_slots``)."""
        return fitted_slots(n_moving, n_static, self.config) if self.fit_slots else self.full_slots

    def prepare(self, n_moving: int | None = None, n_static: int | None = None):
        """Build now (rather than on first need) the controller that solves situations with
        up to ``n_moving`` movers and ``n_static`` static obstacles (each capped at the
        config's slots; None: the config's), e.g. a feature layout's ``k_moving`` and
        ``k_static``. Returns it."""
        m = self.config.max_moving if n_moving is None else min(int(n_moving), self.config.max_moving)
        s = self.config.max_static if n_static is None else min(int(n_static), self.config.max_static)
        return self._controller(self.solver, self.slots_for(m, s))

    def parameters(self, situation: Situation) -> np.ndarray:
        """The NLP parameter vector the planner would use, slots filled as ``decide`` fills them
        for a robot without a previous plan (the desired poses as its predicted path): the
        full NLP's (``config``'s slots), whatever size the labels are solved on."""
        cfg = self.config
        if situation.horizon != cfg.horizon:
            raise ValueError(f"situation horizon {situation.horizon} != planner horizon {cfg.horizon}")
        x0 = situation.robot.as_array()
        sel = self._select(situation)
        return pack_selection(self.layout, x0, situation.ref_poses, sel, cfg, sel.near_walls)

    def _select(self, situation: Situation):
        """The planner's choice of obstacles (with the full config's slots), of the wall
        segments where its NLP has wall slots, and whether the margin near walls applies (the
        planner's rule, :func:`casadi_gpc.problem.selection.near_walls`)."""
        cfg = self.config
        x0 = situation.robot.as_array()
        sel = select_obstacles(x0, situation.forecasts(), situation.statics, cfg)
        if situation.walls:
            if not cfg.max_walls:
                raise ValueError("a situation with walls needs a planner with wall slots "
                                 "(PlannerConfig.for_walls(True))")
            sel.walls, sel.walls_left_out = select_walls(x0, situation.walls, cfg)
        sel.near_walls = near_walls(self.layout, cfg, situation.walls, x0,
                                    walls_reach_m(self.robot, cfg.horizon * cfg.sample_time_s))
        return sel

    def _parameters(self, situation: Situation):
        """The slots ``(moving, static)`` of the NLP that solves ``situation``, its parameter
        vector, and the selected forecasts and statics (what fills the slots)."""
        sel = self._select(situation)
        slots = self.slots_for(len(sel.forecasts), len(sel.statics))
        layout = self.layout if slots == self.full_slots else self._controller(self.solver, slots).problem.layout
        p = pack_selection(layout, situation.robot.as_array(), situation.ref_poses, sel, self.config, sel.near_walls)
        self._walls = getattr(sel, "walls", ())
        return slots, p, sel.forecasts, sel.statics

    def label(self, situation: Situation) -> Label:
        """Solve from every initial guess and keep the planner's choice (with the fallback
        solver if no guess converged)."""
        if situation.horizon != self.config.horizon:
            raise ValueError(f"situation horizon {situation.horizon} != planner horizon {self.config.horizon}")
        slots, p, forecasts, statics = self._parameters(situation)
        obstacle = None  # the one obstacle whose side the near-tie rule looks at
        if self.tie_margin is not None and len(forecasts) + len(statics) == 1:
            H = self.config.horizon
            obstacle = (np.asarray(forecasts[0].means_m, dtype=float) if forecasts
                        else np.tile(np.asarray(statics[0].position_m, dtype=float), (H, 1)))
        self.counters["situations"] += 1
        self.counters["full_nlp" if slots == self.full_slots else "fitted_nlp"] += 1
        key = f"nlp_{slots[0]}x{slots[1]}"
        self.counters[key] = self.counters.get(key, 0) + 1
        label = self._label(self._controller(self.solver, slots), self.solver, situation, p, obstacle)
        if not label.converged and self.fallback_solver is not None:
            self.counters["fallback_used"] += 1
            again = self._label(self._controller(self.fallback_solver, slots), self.fallback_solver, situation, p,
                                obstacle)
            again = replace(again, solves=again.solves + label.solves,
                            solve_time_s=again.solve_time_s + label.solve_time_s)
            if again.converged:
                self.counters["fallback_converged"] += 1
                label = again
            else:  # report the primary solver's failure, with all the work it took
                label = replace(label, solves=again.solves, solve_time_s=again.solve_time_s)
        if not label.converged:
            self.counters["not_converged"] += 1
        return label

    def _label(self, ctl, solver: str, situation: Situation, p: np.ndarray, obstacle: np.ndarray | None = None
               ) -> Label:
        x0 = situation.robot.as_array()
        best, candidates = ctl.plan(p, x0, situation.ref_speed_mps, True, None, self._walls)
        self.counters["solves"] += len(candidates)
        if best is not None and obstacle is not None:
            return self._near_tie_label(ctl, solver, situation, p, obstacle, candidates)
        costs = np.full(len(GUESS_NAMES), np.nan)
        for c in candidates:
            if c.success and c.guess in GUESS_NAMES:
                costs[GUESS_NAMES.index(c.guess)] = c.cost
        t = float(sum(c.solve_time_s for c in candidates))
        H = self.config.horizon
        if best is None:
            status = candidates[0].status if candidates else "no candidates"
            return Label(False, np.full(2, np.nan), np.full((H, 2), np.nan), float("nan"), status, "", -1, costs, t,
                         len(candidates), solver)
        return self._answer(best, candidates, x0, costs, t, solver)

    def _answer(self, best, candidates, x0: np.ndarray, costs: np.ndarray, t: float, solver: str, side: int = 0
                ) -> Label:
        """The label of candidate ``best`` (merged with the starts that reached it)."""
        H = self.config.horizon
        u = _merge_duplicates(best, candidates)
        # the planned wheel speeds: the previous ones plus the cumulated increments (the
        # decision variables of casadi_gpc.problem.cost)
        wheels = x0[3:5] + np.cumsum(u.reshape(H, 2), axis=0)
        return Label(True, wheels[0].copy(), wheels, float(best.cost), best.status, best.guess, best.iterations,
                     costs, t, len(candidates), solver, side, None, self.tie_margin)

    def _near_tie_label(self, ctl, solver: str, situation: Situation, p: np.ndarray, obstacle: np.ndarray,
                        candidates) -> Label:
        """The label under the near-tie convention: the best start on each side, then
        :func:`~nn_export.training.ties.choose` (the other side's kept as ``alternative``)."""
        x0 = situation.robot.as_array()
        costs = np.full(len(GUESS_NAMES), np.nan)
        for c in candidates:
            if c.success and c.guess in GUESS_NAMES:
                costs[GUESS_NAMES.index(c.guess)] = c.cost
        t = float(sum(c.solve_time_s for c in candidates))
        headings = situation.ref_poses[1:, 2]
        best = {}
        for c in candidates:
            if not c.success:
                continue
            poses = to_world(np.asarray(ctl.problem.rollout_fn(c.u, p)[0]), x0)
            side = passing_side(poses, obstacle, headings)
            if side not in best or c.cost < best[side].cost:
                best[side] = c
        answers = {s: self._answer(c, candidates, x0, costs, t, solver, s) for s, c in best.items()}
        pick = choose(answers.get(RIGHT), answers.get(LEFT), self.tie_margin)
        other = answers.get(-pick.side)
        return replace(pick, alternative=other) if other is not None else pick

    def mirror_check(self, situation: Situation, label: Label) -> float:
        """Largest difference (m/s) between the mirrored label and the GPC's answer on the
        mirrored situation (NaN if either did not converge)."""
        other = self.label(situation.mirrored())
        if not (label.converged and other.converged):
            return float("nan")
        return float(np.max(np.abs(label.mirrored().plan_wheels_mps - other.plan_wheels_mps)))

    def sample(self, layout: FeatureLayout, situation: Situation, report: dict | None = None):
        """``(features, label)`` of one situation (label may be unconverged)."""
        return compute_features(layout, situation, report=report), self.label(situation)


def mirrored_sample(layout: FeatureLayout, features: np.ndarray, label: Label) -> tuple[np.ndarray, np.ndarray]:
    """Features and plan of the mirror sample."""
    return mirror_features(layout, features), label.mirrored().plan_wheels_mps
