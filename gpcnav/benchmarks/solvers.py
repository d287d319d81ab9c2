"""The solver benchmark: record the control problems of a closed-loop GPC run, then time
every solver (and, through :func:`policy_rows`, any policy) on the same problems.

The run is recorded with the reference solver (``ipopt-warm``). Each control step with a
previous plan gives one **problem**: its NLP parameters and the warm start, the previous
plan shifted one step with its multipliers, and which of the planner's NLPs it was posed on
(the preset's, or the crowd's with more mover slots at the ticks that track more movers than
the preset's slots hold: :mod:`casadi_gpc.planner.tiers`; each solver solves a problem on
its own NLP). Those are the ``problems`` of BENCH.json. The
planner also solves from its fixed guesses (``casadi_gpc.planner.guesses``) near obstacles and at
a step without a previous plan; those cold starts are recorded as well and reported apart,
under ``multistart``, because from a far start two correct solvers may end in different
local minima.

Every solver solves every problem in one process, interleaved problem by problem (the order
of the solvers rotates), so a burst of load on the machine hits them all alike. Costs are
recomputed with the problem's own cost function, so they compare exactly; the cost of a
failed solve is not used.
"""
from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.problem.cost import GPCProblem
from casadi_gpc.planner.gpc import GPCController
from scenarios.metrics import time_stats
from casadi_gpc.robot import RobotParams
from scenarios.simulator import RunLog, simulate
from casadi_gpc.solvers import (SOLVER_NAMES, Backend, SolveResult, canonical_name, constraint_violation_mps,
                                make_backend)
from casadi_gpc.types import Observation, Policy

__all__ = ["REFERENCE", "SAME_COST_RELATIVE", "AGREE_FRACTION", "RecordedProblem", "Recording",
           "record_problems", "run_solvers", "solver_rows", "policy_rows", "choose_solver", "speedups",
           "run_bench"]

REFERENCE = "ipopt-warm"
"""The planner's solver before this benchmark: the answers every other solver must reach."""
SAME_COST_RELATIVE = 1e-6
"""A cost within this relative distance of the reference's (or lower) is the same answer."""
AGREE_FRACTION = 0.99
"""A solver may be chosen when it is that good on at least this share of the problems."""


@dataclass(frozen=True)
class RecordedProblem:
    """One NLP the planner solved: the parameters and the start it solved from."""

    step: int
    t_s: float
    p: np.ndarray
    u0: np.ndarray
    lam_x: np.ndarray | None
    lam_g: np.ndarray | None
    start: str
    """``warm`` or the name of the guess."""
    primary: bool = False
    """The step's warm-started problem (see the module docstring)."""
    nlp: int = 0
    """Which of the recording planner's NLPs it was posed on (an index into
    :attr:`Recording.configs`)."""


@dataclass
class Recording:
    """A closed-loop run and every problem its planner solved."""

    config: PlannerConfig
    robot: RobotParams
    problems: list
    observations: list
    log: RunLog
    configs: tuple = ()
    """The settings of each NLP the planner had (``RecordedProblem.nlp`` indexes them; the
    first is ``config``'s own)."""

    def nlp_configs(self) -> dict[int, PlannerConfig]:
        """The settings of the NLPs some recorded problem was posed on, by index."""
        configs = self.configs or (self.config,)
        return {k: configs[k] for k in sorted({q.nlp for q in self.problems})}

    @property
    def primary(self) -> list[RecordedProblem]:
        return [q for q in self.problems if q.primary]

    @property
    def multistart(self) -> list[RecordedProblem]:
        return [q for q in self.problems if not q.primary]


class _RecordingController(GPCController):
    """The GPC, writing down each observation and each NLP it solves."""

    def __post_init__(self):
        super().__post_init__()
        self.recorded: list[RecordedProblem] = []
        self.observations: list[Observation] = []

    def decide(self, obs: Observation):
        self.observations.append(obs)
        return super().decide(obs)

    def solve_many(self, p, starts):
        copy = (lambda a: None if a is None else np.array(a, dtype=float))
        self._use_for(p)  # the NLP that takes p, as the solve below does
        nlp = next(k for k, problem in enumerate(self.nlps) if problem is self.problem)
        for guess, u0, lam_x, lam_g in starts:
            self.recorded.append(RecordedProblem(len(self.observations) - 1, self.observations[-1].t_s, copy(p),
                                                 copy(u0), copy(lam_x), copy(lam_g), guess or "unnamed", nlp=nlp))
        return super().solve_many(p, starts)


def record_problems(scenario, config: PlannerConfig) -> Recording:
    """Run ``scenario`` closed loop with the GPC on the reference solver and keep every NLP.
    The GPC runs the full multi-start here (every step: the previous plan warm, and near
    obstacles every fixed guess), so that each step has its one warm-started problem."""
    ctl = _RecordingController(config.with_overrides(solver=REFERENCE, candidates="multistart"), scenario.robot,
                               compile_solver=False)
    log = simulate(scenario, ctl, "gpc")
    by_step: dict[int, list[int]] = {}
    for i, q in enumerate(ctl.recorded):
        by_step.setdefault(q.step, []).append(i)
    primary = {i for idx in by_step.values() for i in idx if ctl.recorded[i].start == "warm"}
    problems = [RecordedProblem(**{**q.__dict__, "primary": i in primary}) for i, q in enumerate(ctl.recorded)]
    return Recording(config, scenario.robot, problems, ctl.observations, log,
                     tuple(problem.config for problem in ctl.nlps))


STEP_PROBLEMS_ONLY = ("powell",)
"""Solvers run on the step problems only: Powell takes seconds per H = 12 solve, and its
multistart answers would add nothing the step problems do not already show."""


def _on(per_nlp, q: RecordedProblem):
    """``per_nlp``'s entry for the NLP ``q`` was posed on: one object for every NLP, or a
    mapping from ``RecordedProblem.nlp`` to one per NLP."""
    return per_nlp[q.nlp] if isinstance(per_nlp, Mapping) else per_nlp


def run_solvers(problems: Sequence[RecordedProblem], backends: dict[str, Backend | Mapping[int, Backend]],
                progress: Callable | None = None,
                step_problems_only: Sequence[str] = STEP_PROBLEMS_ONLY) -> dict[str, list[SolveResult | None]]:
    """Every backend on every problem, interleaved; the solvers' order rotates per problem.
    ``backends[name]``: the solver's backend, or one per NLP (by ``RecordedProblem.nlp``).
    Backends in ``step_problems_only`` get None for the multistart problems."""
    names = list(backends)
    out: dict[str, list] = {n: [] for n in names}
    it = progress(problems) if progress else problems
    for k, q in enumerate(it):
        for j in range(len(names)):
            name = names[(j + k) % len(names)]
            skip = name in step_problems_only and not q.primary
            out[name].append(None if skip else _on(backends[name], q).solve(q.p, q.u0, q.lam_x, q.lam_g))
    return out


def _costs(nlps: GPCProblem | Mapping[int, GPCProblem], problems,
           results: dict[str, list[SolveResult]]) -> dict[str, np.ndarray]:
    """Each solver's cost on each problem by its NLP's own cost function (NaN if failed)."""
    out = {}
    for name, res in results.items():
        out[name] = np.array([float(_on(nlps, q).cost_fn(r.u, q.p)) if r is not None and r.success else np.nan
                              for r, q in zip(res, problems)])
    return out


def _summary(nlps, problems, results, costs, name: str, reference: str) -> dict:
    res = results[name]
    ok = np.array([r.success for r in res], dtype=bool)
    with warnings.catch_warnings():  # a problem every solver failed has no best: NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        best = np.nanmin(np.vstack(list(costs.values())), axis=0)
    c = costs[name]
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = c / np.maximum(best, 1e-300)
    ratio = ratio[np.isfinite(ratio)]
    row = {
        "problems": len(res),
        "time_s": time_stats(r.solve_time_s for r in res),
        "iterations": {"median": float(np.median([r.iterations for r in res])) if res else 0.0},
        "success_rate": float(ok.mean()) if len(ok) else 0.0,
        "cost_ratio_to_best": {"median": float(np.median(ratio)) if ratio.size else float("nan"),
                               "max": float(np.max(ratio)) if ratio.size else float("nan")},
        "constraint_violation_mps": {"max": max((constraint_violation_mps(_on(nlps, q), r.u, q.p)
                                                 for r, q in zip(res, problems) if r.success), default=0.0)},
    }
    if reference in costs:
        ref = costs[reference]
        both = np.isfinite(ref) & np.isfinite(c)
        tol = SAME_COST_RELATIVE * np.abs(ref)
        as_good = both & (c <= ref + tol)
        row["vs_reference"] = {
            "reference": reference,
            "compared": int(both.sum()),
            # the share of all problems (failures count against) with a cost at least as good
            "as_good_rate": float(as_good.sum() / max(len(res), 1)),
            "worse": int((both & (c > ref + tol)).sum()),
            "better": int((both & (c < ref - tol)).sum()),
            "max_relative_excess": float(np.max(((c - ref) / np.abs(ref))[both], initial=0.0)),
        }
    evals = [r.evaluations for r in res if r.evaluations]
    if evals:
        row["cost_evaluations"] = {"median": float(np.median(evals)), "max": int(max(evals))}
    fails = sorted({r.status for r in res if not r.success})
    if fails:
        row["failure_statuses"] = fails[:5]
    return row


def _finite_or_none(doc):
    """JSON has no NaN: replace non-finite numbers by None."""
    if isinstance(doc, dict):
        return {k: _finite_or_none(v) for k, v in doc.items()}
    if isinstance(doc, list):
        return [_finite_or_none(v) for v in doc]
    if isinstance(doc, float) and not math.isfinite(doc):
        return None
    return doc


def _step_agreement(steps: np.ndarray, cost: np.ndarray, ref: np.ndarray) -> dict:
    """What the planner keeps at each step is its cheapest candidate: compare those."""
    as_good = worse = better = 0
    for s in np.unique(steps):
        mine, theirs = cost[steps == s], ref[steps == s]
        a = np.min(mine[np.isfinite(mine)], initial=np.inf)
        b = np.min(theirs[np.isfinite(theirs)], initial=np.inf)
        tol = SAME_COST_RELATIVE * abs(b) if math.isfinite(b) else 0.0
        as_good += int(a <= b + tol)
        worse += int(a > b + tol)
        better += int(a < b - tol)
    n = len(np.unique(steps))
    return {"steps": n, "as_good_rate": as_good / max(n, 1), "worse": worse, "better": better}


def solver_rows(nlps: GPCProblem | Mapping[int, GPCProblem], recording: Recording,
                results: dict[str, list[SolveResult]], backends: dict[str, Backend | Mapping[int, Backend]],
                reference: str = REFERENCE) -> list[dict]:
    """One BENCH row per solver: the step problems, and the multistart solves under ``multistart``.
    ``nlps`` and ``backends[name]``: one for every problem, or one per NLP (``RecordedProblem.nlp``)."""
    prim = [i for i, q in enumerate(recording.problems) if q.primary]
    multi = [i for i, q in enumerate(recording.problems) if not q.primary]
    rows = []
    parts = {}
    for label, idx in (("primary", prim), ("multistart", multi)):
        qs = [recording.problems[i] for i in idx]
        sub = {n: [r[i] for i in idx] for n, r in results.items()}
        costs = _costs(nlps, qs, sub)
        parts[label] = (qs, sub, costs)
    all_costs = _costs(nlps, recording.problems, results)
    steps = np.array([q.step for q in recording.problems])
    for name in results:
        qs, sub, costs = parts["primary"]
        row = {"name": name, "kind": "solver", **_summary(nlps, qs, sub, costs, name, reference)}
        qs_m, sub_m, costs_m = parts["multistart"]
        ran_all = all(r is not None for r in results[name])
        if qs_m and ran_all:
            row["multistart"] = _summary(nlps, qs_m, sub_m, costs_m, name, reference)
        if reference in all_costs and ran_all:
            row["planner_steps"] = _step_agreement(steps, all_costs[name], all_costs[reference])
        if ran_all:
            # what the planner spends solving in this run: step and multistart solves
            row["total_time_s"] = float(sum(r.solve_time_s for r in results[name]))
        per_nlp = backends[name] if isinstance(backends[name], Mapping) else {0: backends[name]}
        notes = [note if len(per_nlp) == 1 else f"NLP {k}: {note}" for k, b in per_nlp.items() for note in b.notes]
        notes += [] if ran_all else ["run on the step problems only"]
        row.update({"compiled": all(b.compiled for b in per_nlp.values()), "notes": notes,
                    "time_samples_s": [r.solve_time_s for r in sub[name]]})
        rows.append(_finite_or_none(row))
    return rows


def policy_rows(recording: Recording, policies: Sequence[tuple[str, Callable[[], Policy]]]) -> list[dict]:
    """The extension point for policies (the GPC's full decision, the networks, ...).

    ``policies``: ``(name, make_policy)`` pairs; ``make_policy()`` returns an object with
    ``reset()`` and ``decide(observation) -> ControlDecision``. Each is reset and given the
    recorded observations in order (open loop: its commands are not applied), and its
    ``decide`` is timed. Reported beside the time: fallbacks, and how far its first
    command is from the recorded GPC's (m/s)."""
    recorded = np.array([[d.v_right_mps, d.v_left_mps] for d in recording.log.decisions])
    rows = []
    for name, make_policy in policies:
        policy = make_policy()
        policy.reset()
        times, cmds, fallbacks = [], [], 0
        for obs in recording.observations:
            t0 = time.perf_counter()
            dec = policy.decide(obs)
            times.append(time.perf_counter() - t0)
            cmds.append((dec.v_right_mps, dec.v_left_mps))
            fallbacks += int(dec.fallback)
        diff = np.max(np.abs(np.asarray(cmds, float) - recorded), axis=1) if len(cmds) else np.zeros(0)
        row = {"name": name, "kind": "policy", "problems": len(times), "time_s": time_stats(times),
               "fallbacks": fallbacks,
               "command_diff_to_recorded_mps": {"median": float(np.median(diff)) if diff.size else 0.0,
                                                "max": float(np.max(diff)) if diff.size else 0.0},
               "time_samples_s": times}
        info = getattr(policy, "solver_info", None)
        if info:
            row["solver"] = info
        rows.append(_finite_or_none(row))
    return rows


def choose_solver(rows: list[dict], reference: str = REFERENCE) -> tuple[str, str]:
    """The solver with the least total solve time (all recorded solves: what the planner
    spends) among those that give the reference's answers:

    - every recorded solve succeeded, warm and cold;
    - on the warm-started problems, a cost within :data:`SAME_COST_RELATIVE` of the
      reference's or lower on at least :data:`AGREE_FRACTION` of them;
    - the planner's cheapest candidate as good at :data:`AGREE_FRACTION` of the steps;
    - from the cold starts, not more often worse than the reference than better (no
      solver follows IPOPT's path from a far start exactly; a systematic bias is the fault).
    """
    def agrees(r):
        if r["name"] == reference:
            return True
        ms = r.get("multistart") or {}
        vs = ms.get("vs_reference") or {}
        return ((r.get("vs_reference") or {}).get("as_good_rate", 0.0) >= AGREE_FRACTION
                and (r.get("planner_steps") or {}).get("as_good_rate", 0.0) >= AGREE_FRACTION
                and ms.get("success_rate", 0.0) == 1.0 and vs.get("worse", 1) <= vs.get("better", 0))
    ok = [r for r in rows if r["kind"] == "solver" and r["success_rate"] == 1.0 and agrees(r)]
    if not ok:
        return reference, "no solver met the rule; the reference is kept"
    best = min(ok, key=lambda r: (r.get("total_time_s") or math.inf, r["time_s"]["median"]))
    rule = (f"least total solve time among solvers with 100% success on every recorded solve, a cost within "
            f"{SAME_COST_RELATIVE:g} (relative) of {reference}'s or better on >= {AGREE_FRACTION:.0%} of the "
            f"warm-started problems, the planner's cheapest candidate as good on >= {AGREE_FRACTION:.0%} of the "
            f"steps, and from the cold starts not more often worse than {reference} than better")
    return best["name"], rule


def speedups(rows: list[dict], chosen: str, reference: str = REFERENCE) -> dict:
    """Median-time ratios: the reference over every row, and every solver over the chosen one."""
    med = {r["name"]: r["time_s"]["median"] for r in rows}
    out = {}
    if reference in med:
        out.update({f"{reference}/{n}": med[reference] / m for n, m in med.items() if n != reference and m > 0})
    if chosen in med and med[chosen] > 0:
        out.update({f"{n}/{chosen}": m / med[chosen] for n, m in med.items() if n != chosen})
    return out


def run_bench(scenario, config: PlannerConfig, solvers: Sequence[str] = SOLVER_NAMES,
              policies: Sequence[tuple[str, Callable[[], Policy]]] = (), gpc_rows: bool = True,
              progress: Callable | None = None, compiled: bool = True, say: Callable[[str], None] | None = None,
              decision_scenarios: Sequence = ()) -> dict:
    """Record ``scenario`` under ``config``, run ``solvers`` (the reference is always added)
    on its problems and ``policies`` on its observations; returns the BENCH document.

    ``gpc_rows`` adds two policy rows, the full GPC decision (estimation included) with the
    reference solver and with the chosen one, replayed on the recorded observations.
    ``decision_scenarios`` (a crowd scene, say) are run closed loop with the planner as shipped,
    beside ``scenario`` itself (:mod:`gpcnav.benchmarks.decisions`): decision times, solves
    per decision, and the persistent candidates against the full multi-start."""
    say = say or (lambda msg: None)
    names = list(dict.fromkeys([REFERENCE, *solvers]))
    say(f"recording the control problems of {scenario.name} (preset {config.name}, H={config.horizon}, "
        f"T={config.sample_time_s} s)")
    recording = record_problems(scenario, config)
    if not recording.problems:
        raise ValueError(f"{scenario.name}: the run posed the planner no problem ({len(recording.log.compute_time_s)} "
                         f"decisions): nothing to time")
    from casadi_gpc.problem.cost import build_problem
    # every NLP a recorded problem was posed on (the crowd's too, where the run had more movers
    # than the preset's slots), each solver built on each
    nlps = {k: build_problem(c, scenario.robot) for k, c in recording.nlp_configs().items()}
    backends = {}
    for name in names:
        backends[name] = {}
        for k, nlp in nlps.items():
            t0 = time.perf_counter()
            what = name if len(nlps) == 1 else f"{name} on NLP {k} ({nlp.config.max_moving} mover slots)"
            say(f"building {what}")
            backends[name][k] = make_backend(name, nlp, compiled=compiled)
            say(f"  {what}: {'; '.join(backends[name][k].notes)} ({time.perf_counter() - t0:.1f} s)")
    results = run_solvers(recording.problems, backends, progress)
    rows = solver_rows(nlps, recording, results, backends)
    chosen, rule = choose_solver(rows)
    extra = list(policies)
    if gpc_rows:
        def gpc(solver):
            return lambda: GPCController(config.with_overrides(solver=solver), scenario.robot, compile_solver=compiled)
        extra = [(f"gpc[{name}]", gpc(name)) for name in dict.fromkeys((REFERENCE, chosen))] + extra
    rows += policy_rows(recording, extra)
    by_name = {r["name"]: r for r in rows}
    ch = by_name[chosen]
    doc = {
        "problems": len(recording.primary),
        "multistart_problems": len(recording.multistart),
        "scenario": scenario.name,
        "preset": config.name,
        "horizon": config.horizon,
        "sample_time_s": config.sample_time_s,
        "reference": REFERENCE,
        "recorded_run": {"outcome": recording.log.outcome, "steps": len(recording.log.compute_time_s)},
        "nlps": [{"index": k, "moving_slots": nlp.config.max_moving, "static_slots": nlp.config.max_static,
                  "wall_slots": nlp.config.max_walls, "parameters": nlp.layout.size,
                  "problems": sum(q.nlp == k for q in recording.problems)} for k, nlp in nlps.items()],
        "chosen": {"name": chosen, "rule": rule, "median_time_s": ch["time_s"]["median"],
                   "speedup_vs_reference": by_name[REFERENCE]["time_s"]["median"] / ch["time_s"]["median"],
                   "success_rate": ch["success_rate"],
                   "as_good_as_reference_rate": (ch.get("vs_reference") or {}).get("as_good_rate", 1.0)},
        "results": rows,
        "speedup": speedups(rows, chosen),
        "decisions": decision_rows([scenario, *decision_scenarios], config, *_planner_solve(by_name, config, chosen),
                                   say),
        "timing": "time_s: wall time of one solve called from Python (conversions included), one call per "
                  "problem, solvers interleaved problem by problem",
    }
    return _finite_or_none(doc)


def _planner_solve(by_name: dict, config: PlannerConfig, chosen: str) -> tuple[str, float]:
    """The solver the planner runs (``config.solver``) and its median warm solve in this run,
    where it was benched; else the chosen one's."""
    name = canonical_name(config.solver)
    row = by_name.get(name)
    if row is None or row.get("kind") != "solver":
        name, row = chosen, by_name[chosen]
    return name, row["time_s"]["median"]


def decision_rows(scenarios, config: PlannerConfig, warm_solver: str, warm_solve_median_s: float,
                  say) -> list[dict]:
    """The planner's whole decision on each scenario (closed loop, as shipped) beside one
    warm solve of ``warm_solver`` (the planner's own where it was benched), and its
    persistent candidates against the full multi-start on the same recorded problems."""
    from .decisions import compare_candidates, decision_run, record_ticks
    out = []
    for sc in scenarios:
        say(f"the planner's decision on {sc.name} ({len(sc.moving)} movers), and its candidates against the "
            f"full multi-start")
        row = decision_run(sc, config)
        row["single_warm_solve_median_s"], row["single_warm_solver"] = warm_solve_median_s, warm_solver
        row["decision_over_warm_solve"] = row["time_s"]["median"] / warm_solve_median_s
        row["candidates_vs_multistart"] = compare_candidates(record_ticks(sc, config), config, sc.robot)
        out.append(row)
    return out
