"""The planner's whole decision: its time in closed loop, and its persistent candidates
against the full multi-start on the same recorded problems (``gpcnav bench``'s decision rows).

:func:`decision_run` runs a scenario closed loop with the planner as shipped (the GPC behind
its check layer) and reports its decision times, solves per decision and how often the
fixed guesses were solved.

:func:`record_ticks` runs a scenario closed loop with the full multi-start
(``PlannerConfig.candidates = "multistart"``: every fixed guess and the previous plan at every
step near obstacles) and keeps each step's NLP (:class:`casadi_gpc.planner.gpc.Tick`) and the cost
of the plan it chose. :func:`compare_candidates` solves the same sequence of NLPs with the
persistent candidates (:mod:`casadi_gpc.planner.candidates`), which carry their own solutions from
step to step, and compares the chosen costs step by step: the same (within
:data:`SAME_COST_RELATIVE`) or lower counts as as good.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.planner.gpc import GPCController, Tick
from scenarios.metrics import time_stats
from casadi_gpc.robot import RobotParams
from scenarios.simulator import simulate

__all__ = ["SAME_COST_RELATIVE", "decision_time_stats", "deployed_against_gpc", "RecordedTick", "record_ticks",
           "compare_candidates", "decision_run", "crowd_decisions"]

SAME_COST_RELATIVE = 1e-6
"""A chosen cost within this relative distance of the full multi-start's (or lower) is as good."""


@dataclass(frozen=True)
class RecordedTick:
    """One step of the full multi-start's closed loop."""

    tick: Tick
    cost: float
    """The chosen plan's cost (NaN when every solve failed)."""
    solves: int


class _Recorder(GPCController):
    def __post_init__(self):
        super().__post_init__()
        self.ticks: list[RecordedTick] = []

    def solve_tick(self, tick: Tick):
        best, solved = super().solve_tick(tick)
        self.ticks.append(RecordedTick(tick, float("nan") if best is None else best.cost, len(solved)))
        return best, solved


def record_ticks(scenario, config: PlannerConfig) -> list[RecordedTick]:
    """Every step's NLP and chosen cost of ``scenario`` run closed loop by the GPC with the
    full multi-start (the rest of ``config`` as given)."""
    ctl = _Recorder(config.with_overrides(candidates="multistart"), scenario.robot)
    simulate(scenario, ctl, "gpc")
    return ctl.ticks


def compare_candidates(ticks: list[RecordedTick], config: PlannerConfig, robot: RobotParams | None = None) -> dict:
    """The persistent candidates on the recorded sequence ``ticks``: how often their chosen
    cost is as good as the full multi-start's, the largest excess, and the solves per step
    of each. Steps where the multi-start found no plan are not compared."""
    per = GPCController(config.with_overrides(candidates="persistent"), robot or RobotParams())
    compared = as_good = 0
    excess, solves_ms, solves_pc = [], [], []
    for r in ticks:
        best, solved = per.solve_tick(r.tick)
        if not np.isfinite(r.cost):
            continue
        compared += 1
        solves_ms.append(r.solves)
        solves_pc.append(len(solved))
        cost = np.inf if best is None else best.cost
        rel = (cost - r.cost) / max(abs(r.cost), 1e-12)
        excess.append(rel)
        as_good += bool(rel <= SAME_COST_RELATIVE)
    return {"steps": compared, "as_good": as_good, "as_good_rate": as_good / max(compared, 1),
            "worse": compared - as_good, "max_relative_excess": float(max(excess, default=0.0)),
            "solves_per_step": {"multistart": float(np.mean(solves_ms)) if solves_ms else 0.0,
                                "persistent": float(np.mean(solves_pc)) if solves_pc else 0.0}}


def decision_time_stats(values) -> dict:
    """:func:`~scenarios.metrics.time_stats` with the 99th percentile (``p99``): the tail a
    real-time loop must budget for."""
    out = time_stats(values)
    out["p99"] = float(np.percentile(np.asarray(list(values), dtype=float), 99)) if out["count"] else 0.0
    return out


def policy_decision_run(scenario, name: str, policy) -> dict:
    """``scenario`` closed loop with ``policy`` (any controller, e.g. the network behind its
    check layer): its decision times as the simulator takes them (features, network, check:
    everything ``decide`` does), interventions, fallbacks and the outcome; and, where the
    decisions say it (:meth:`nn_export.OnnxPolicy.decide` behind a
    :class:`~casadi_gpc.safety.Shield`), the medians of the decision's parts
    (:func:`decision_parts`)."""
    log = simulate(scenario, policy, name)
    return {"scenario": scenario.name, "controller": name, "outcome": log.outcome, "decisions": len(log.decisions),
            "movers": len(scenario.moving), "time_s": decision_time_stats(log.compute_time_s),
            "parts_s": decision_parts(log.decisions, log.compute_time_s),
            "parts_p99_s": decision_parts(log.decisions, log.compute_time_s, 99),
            "interventions": int(log.events.get("interventions", 0)),
            "fallbacks": int(sum(bool(d.fallback) for d in log.decisions)),
            "min_clearance_m": float(log.min_clearance_m), "time_samples_s": list(log.compute_time_s)}


def decision_parts(decisions, times_s, percentile: float = 50) -> dict | None:
    """Medians (or another ``percentile``) over the decisions of where their time went (None
    unless every decision says it): ``estimation`` (the filters' updates, the desired poses and the forecasts:
    ``estimation_time_s`` + ``forecast_time_s``), ``network`` (the features and the network's
    calls, ``network_time_s``), ``check`` (``safety_time_s``, the fallback's time included
    where it stepped in) and ``rest`` (the decision's time less those three)."""
    keys = ("estimation_time_s", "forecast_time_s", "network_time_s", "safety_time_s")
    if not decisions or any(k not in d.info for d in decisions for k in keys):
        return None
    est = [d.info["estimation_time_s"] + d.info["forecast_time_s"] for d in decisions]
    net = [d.info["network_time_s"] for d in decisions]
    chk = [d.info["safety_time_s"] for d in decisions]
    rest = [t - a - b - c for t, a, b, c in zip(times_s, est, net, chk)]
    return {k: float(np.percentile(v, percentile)) for k, v in (("estimation", est), ("network", net),
                                                                ("check", chk), ("rest", rest))}


def decision_run(scenario, config: PlannerConfig) -> dict:
    """``scenario`` closed loop with the GPC behind its check layer (as ``gpcnav --controller
    gpc`` runs it): the decision's time (median, p95, max), solves per decision, the share of
    decisions that solved the fixed guesses, interventions, the outcome. Each decision is
    timed as the simulator times it (estimation, parameters, solves, the check)."""
    from ..controllers import ControllerSpec, make  # the check settings ``--controller gpc`` runs with
    shielded = make(ControllerSpec("gpc"), config, scenario.robot)
    gpc = shielded.policy
    log = simulate(scenario, shielded, "gpc")
    n = max(len(log.decisions), 1)
    return {"scenario": scenario.name, "preset": config.name, "outcome": log.outcome, "decisions": len(log.decisions),
            "movers": len(scenario.moving), "time_s": decision_time_stats(log.compute_time_s),
            "solves_per_decision": gpc.counters["solves"] / n,
            "full_multistart_share": gpc.counters["full_multistarts"] / n,
            "interventions": int(log.events.get("interventions", 0)), "min_clearance_m": float(log.min_clearance_m),
            "time_samples_s": list(log.compute_time_s)}


def deployed_against_gpc(gpc_rows, network_rows) -> list[dict]:
    """For each scene with both rows (same ``scenario`` name, the same ``gpcnav bench`` run):
    the GPC's decision time over the deployed network's, at the median, p99 and max."""
    by_scene = {r["scenario"]: r for r in gpc_rows}
    out = []
    for n in network_rows:
        g = by_scene.get(n["scenario"])
        if g is None:
            continue
        out.append({"scenario": n["scenario"], "network": n["controller"], "movers": n["movers"],
                    **{f"speedup_{k}": g["time_s"][k] / max(n["time_s"][k], 1e-12) for k in ("median", "p99", "max")}})
    return out


def crowd_decisions(scenarios, config: PlannerConfig | None, make_network=None, progress=None) -> dict:
    """The decisions of the GPC behind its check (``config``; None: not run) and of the
    deployed network (``make_network(scenario)``: a new policy; None: not run) over the same
    ``scenarios``, the two run one after the other on each scene (so that the machine's swings
    fall on both), pooled: a 99th percentile needs a few hundred decisions, which one crossing
    (about 45) does not give. Per controller: the pooled decision times
    (:func:`decision_time_stats`), outcomes, and for the network the parts of its decisions
    (:func:`decision_parts`) and the check's interventions; and the GPC's times over the
    network's at the median, p99 and max where both ran. ``progress``: wraps the scenes' loop (a bar).

    The objects made before (the bench's recorded problems, its solvers) are frozen out of the
    garbage collector's reach while the scenes run (``gc.freeze``, as a robot's control loop would
    after loading its policy, docs/nn-deploy.md): a full collection over them landed in one
    decision, 0.1-0.15 s in three bench runs of 2026-12-02, the same decision each time."""
    import gc
    from collections import Counter

    from ..controllers import ControllerSpec, make
    runs = {}
    if config is not None:
        runs["gpc"] = lambda sc: make(ControllerSpec("gpc"), config, sc.robot)
    if make_network is not None:
        runs["nn"] = make_network
    pooled = {k: {"times": [], "decisions": [], "outcomes": Counter(), "interventions": 0} for k in runs}
    gc.collect()
    gc.freeze()
    try:
        for sc in (progress(scenarios) if progress else scenarios):
            for name, new in runs.items():
                log = simulate(sc, new(sc), name)
                acc = pooled[name]
                acc["times"] += list(log.compute_time_s)
                acc["decisions"] += list(log.decisions)
                acc["outcomes"][log.outcome] += 1
                acc["interventions"] += int(log.events.get("interventions", 0))
    finally:
        gc.unfreeze()
    out = {"scenarios": [sc.name for sc in scenarios], "episodes": len(scenarios)}
    for name, acc in pooled.items():
        row = {"decisions": len(acc["times"]), "time_s": decision_time_stats(acc["times"]),
               "outcomes": dict(sorted(acc["outcomes"].items())), "interventions": acc["interventions"],
               "time_samples_s": [float(t) for t in acc["times"]]}
        parts = decision_parts(acc["decisions"], acc["times"])
        if parts is not None:
            row["parts_s"], row["parts_p99_s"] = parts, decision_parts(acc["decisions"], acc["times"], 99)
        out[name] = row
    if "gpc" in out and "nn" in out:
        g, n = out["gpc"]["time_s"], out["nn"]["time_s"]
        out["gpc_over_nn"] = {k: g[k] / max(n[k], 1e-12) for k in ("median", "p99", "max")}
    return out
