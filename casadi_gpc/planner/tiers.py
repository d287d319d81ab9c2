"""The NLPs one controller solves, each with what solves it: the preset's, and, where
:attr:`casadi_gpc.config.PlannerConfig.crowd_moving` is set, a second with more mover slots
for the ticks where the controller tracks more movers than the first holds (:func:`crowded`).

Among 30 walkers crossing a square, 10 slots left out the movers the plan then ran into
(docs/pedestrians.md, "Slots for a crowd"); an NLP with more slots costs more at every
solve, so it is solved only at those ticks. Everything an NLP's size shapes lives here: the
problem, the backend and its backup, the roll-out, the lanes. A kept plan warm-starts either
NLP whole: the decision variables (the increments) and the constraints (the wheels' speed
limits) do not depend on the slots, only the parameters and the cost do
(``tests/test_crowd_tiers.py``).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..buffered import BufferedFunction
from ..config import PlannerConfig
from ..problem.cost import GPCProblem, build_problem
from ..robot import RobotParams
from ..solvers import Backend, make_backend, same_iterates, start_backend
from ..solvers.compiling import while_compiling
from .lanes import SolveLanes

BACKUP_SHARE = 0.5
"""The backup solver runs only while this share of the step's time budget is left, and stops
itself after that long (IPOPT's ``max_wall_time``): with a 0.5 s budget it started with any
time left and, given the whole budget, took one decision to 0.51 s under load."""


@dataclass
class SolveTier:
    """One NLP and what solves it (``problem.config``: the controller's settings with this
    NLP's slots)."""

    problem: GPCProblem
    backend: Backend
    backup: Backend | None
    rollout: BufferedFunction
    ref_slice: slice
    lanes: SolveLanes | None = None


def build_tier(config: PlannerConfig, robot: RobotParams, time_budget_s: float, compiled: bool,
               ipopt_options: dict, backup_solver: str | None) -> SolveTier:
    """The NLP of ``config`` for ``robot``, its backend (IPOPT also stops itself at the
    budget: C code cannot be interrupted from Python; the SQP and fatrop are capped by their
    iteration limits) and, unless it is the same solver, the backup that stops itself at
    :data:`BACKUP_SHARE` of the budget (a decision never outlives its sample time)."""
    problem = build_problem(config, robot)
    if backup_solver is not None and same_iterates(backup_solver, config.solver):
        backup_solver = None  # it would fail where the main solver failed, step for step
    # the backup's compile (IPOPT's, where its library is not cached yet) runs in its own
    # process while the main solver's compile runs here: a fresh cache waits for the longer
    started = None if backup_solver is None else start_backend(backup_solver, problem, compiled)
    backend = while_compiling(started, lambda: make_backend(config.solver, problem, max_wall_time_s=time_budget_s,
                                                            compiled=compiled, ipopt_options=ipopt_options))
    backup = None
    if backup_solver is not None:
        backup = make_backend(backup_solver, problem, max_wall_time_s=BACKUP_SHARE * time_budget_s,
                              compiled=compiled, ipopt_options=ipopt_options)
    return SolveTier(problem, backend, backup, BufferedFunction(problem.rollout_fn),
                     problem.layout.slices()["ref"])


def crowd_config(config: PlannerConfig) -> PlannerConfig | None:
    """The settings of the crowd NLP (``crowd_moving`` slots), None without one."""
    if config.crowd_moving is None or config.crowd_moving <= config.max_moving:
        return None
    return replace(config, max_moving=config.crowd_moving, crowd_moving=None)


def crowded(config: PlannerConfig, forecasts) -> bool:
    """Whether the controller tracks more movers than ``config.max_moving`` slots hold.

    Not only the relevant ones (within ``relevance_range_m`` of the predicted path): among 30
    walkers, the crowd NLP at the ticks where more than 10 were relevant was hit in 4 of 40
    crossings on each of two development seeds, the crowd NLP at every tick of a crowd in 2 and
    1 (docs/pedestrians.md, "Slots for a crowd"): a mover that is not relevant to the
    predicted path now is there when the plan changes."""
    return len(forecasts) > config.max_moving
