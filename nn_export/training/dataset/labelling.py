"""Labelling situations into shard arrays: one labeller per worker process (its solvers built
once), the GPC's label and the mirror sample of every converged situation, and shard
``i`` of a spec computed from the generator seeded with ``[seed, i]`` (deterministic)."""
from __future__ import annotations

import time

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.robot import RobotParams

from ...runtime.features import compute_features, mirror_features
from ...runtime.layouts import FeatureLayout
from ...runtime.tracker import SituationTracker
from ..labels import GUESS_NAMES, Labeller
from ..sampler import sample_situation
from ..two_pass import two_pass_stream
from .spec import MIRROR_TOLERANCE_MPS, SHARD_STRIDE, DatasetSpec

__all__ = ["prepare_labeller", "labeller_for", "ShardBuilder", "new_stats", "label_situations", "label_shard",
           "peak_rss_mb"]

_LABELLERS: dict = {}
"""One labeller per process and request: its solvers are built once."""


def prepare_labeller(spec: DatasetSpec) -> Labeller:
    """Build (once per process) the labeller ``spec`` needs, with the NLP that holds the
    obstacles of its feature layout (``k_moving``, ``k_static``: the paper layout's one mover
    needs the smallest, :meth:`Labeller.prepare`); raises ValueError for an unknown solver.
    Local workers are forked after this, so they inherit it built."""
    labeller = labeller_for(spec.config, spec.robot, spec.solver, spec.tie_margin)
    labeller.prepare(spec.layout.k_moving, spec.layout.k_static)
    return labeller


def labeller_for(config: PlannerConfig, robot: RobotParams, solver: str | None,
                 tie_margin: float | None = None) -> Labeller:
    """The labeller of this process for ``(config, robot, solver, tie_margin)``, built on first use.
    It solves each situation on the smallest NLP that holds the obstacles the planner
    selects (:class:`Labeller`, sizes built on first need; the same labels as the full NLP's);
    ``config``, with its full slots, is what it selects with and what a dataset records."""
    key = (config, robot, solver, tie_margin)
    if key not in _LABELLERS:
        _LABELLERS[key] = Labeller(config, robot, solver, tie_margin=tie_margin)
    return _LABELLERS[key]


class ShardBuilder:
    """Accumulates samples of one shard as arrays of known size."""

    def __init__(self, n: int, F: int, H: int):
        self.n, self.k = n, 0
        self.a = {
            "features": np.empty((n, F)), "labels": np.empty((n, 2)), "plan_wheels_mps": np.empty((n, H, 2)),
            "cost": np.empty(n), "status": [], "guess": [], "solver": [], "iterations": np.empty(n, dtype=np.int32),
            "candidate_costs": np.empty((n, len(GUESS_NAMES))), "mirror": np.zeros(n, dtype=bool),
            "situation_id": np.empty(n, dtype=np.int64), "sample_id": np.empty(n, dtype=np.int64),
            "mirror_check_mps": np.full(n, np.nan), "decision_pass": np.zeros(n, dtype=np.int8),
        }

    @property
    def full(self) -> bool:
        return self.k >= self.n

    def add(self, features, plan, label, situation_id: int, mirror: bool, check=float("nan"),
            decision_pass: int = 0) -> None:
        """One sample; ``label``: the answer of this sample's situation (for a mirror sample,
        the mirrored label: its guess and candidate costs are stored as they are)."""
        a, k = self.a, self.k
        a["features"][k] = features
        a["labels"][k] = plan[0]
        a["plan_wheels_mps"][k] = plan
        a["cost"][k] = label.cost
        a["status"].append(label.status)
        a["solver"].append(label.solver)
        a["guess"].append(label.guess)
        a["iterations"][k] = label.iterations
        a["candidate_costs"][k] = label.candidate_costs
        a["mirror"][k] = mirror
        a["situation_id"][k] = situation_id
        a["sample_id"][k] = 2 * situation_id + int(mirror)
        a["mirror_check_mps"][k] = check
        a["decision_pass"][k] = decision_pass
        self.k += 1

    def arrays(self) -> dict:
        out = dict(self.a)
        out["status"] = np.array(out["status"], dtype=str)
        out["guess"] = np.array(out["guess"], dtype=str)
        out["solver"] = np.array(out["solver"], dtype=str)
        return out


def new_stats() -> dict:
    return {"situations": 0, "not_converged": 0, "answered_by_fallback_solver": 0, "failure_statuses": {}, "solves": 0,
            "solve_time_s": 0.0,
            "mirror_checked": 0, "mirror_check_failed": 0, "mirror_max_diff_mps": 0.0,
            "mirror_over_tolerance": 0, "mirror_check_replaced": 0, "features": {}, "elapsed_s": 0.0}


def label_situations(builder: ShardBuilder, stats: dict, situations, layout: FeatureLayout, labeller: Labeller,
                      mirror: bool, check_every: int, id_base: int) -> None:
    """Label situations from an iterator into ``builder`` until it is full. Items are
    situations, or ``(situation, label)`` pairs already labelled by ``labeller``."""
    j = 0
    for item in situations:
        if builder.full:
            break
        sit, label = item if isinstance(item, tuple) else (item, None)
        label = label or labeller.label(sit)
        stats["situations"] += 1
        if label.converged and label.solver != labeller.solver:
            stats["answered_by_fallback_solver"] += 1
        stats["solves"] += label.solves
        stats["solve_time_s"] += label.solve_time_s
        if not label.converged:
            stats["not_converged"] += 1
            fs = stats["failure_statuses"]
            fs[label.status] = fs.get(label.status, 0) + 1
            continue
        f = compute_features(layout, sit, report=stats["features"])
        check = float("nan")
        if check_every and j % check_every == 0:
            other = labeller.label(sit.mirrored())
            stats["solves"] += other.solves
            if other.converged:
                check = float(np.max(np.abs(label.mirrored().wheels_mps - other.wheels_mps)))
                stats["mirror_checked"] += 1
                stats["mirror_max_diff_mps"] = max(stats["mirror_max_diff_mps"], check)
                if check > MIRROR_TOLERANCE_MPS:
                    stats["mirror_over_tolerance"] += 1
                    # the two sides' multi-starts reached different optima: the cheaper one is
                    # the GPC's answer for both (the other side's starts missed it)
                    if other.cost < label.mirrored().cost:
                        label = other.mirrored()
                        stats["mirror_check_replaced"] += 1
            else:
                stats["mirror_check_failed"] += 1
        sid = id_base + j
        which = int(sit.info.get("decision_pass", 0))
        builder.add(f, label.plan_wheels_mps, label, sid, False, check, which)
        if mirror and not builder.full:
            m = label.mirrored()
            builder.add(mirror_features(layout, f), m.plan_wheels_mps, m, sid, True, decision_pass=which)
        j += 1


def label_shard(spec: DatasetSpec, index: int) -> tuple[int, dict, dict]:
    """Compute shard ``index`` of ``spec``: ``(index, arrays, stats)``. Deterministic."""
    t0, c0 = time.perf_counter(), time.process_time()
    labeller = labeller_for(spec.config, spec.robot, spec.solver, spec.tie_margin)
    n = spec.shard_samples(index)
    builder = ShardBuilder(n, spec.layout.size, spec.config.horizon)
    stats = new_stats()
    rng = np.random.default_rng([spec.seed, index])
    tracker = SituationTracker(spec.config)

    def stream():
        if spec.scheme == "two-pass":
            yield from two_pass_stream(rng, spec.config, labeller, spec.robot, spec.sampler)
        while True:
            yield sample_situation(rng, spec.config, spec.layout.name, spec.robot, spec.sampler, tracker)

    label_situations(builder, stats, stream(), spec.layout, labeller, spec.mirror, spec.mirror_check_every,
                      index * SHARD_STRIDE)
    stats["elapsed_s"] = time.perf_counter() - t0
    stats["cpu_s"] = time.process_time() - c0
    stats["worker_peak_rss_mb"] = peak_rss_mb()
    return index, builder.arrays(), stats


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far, MB (Linux reports kB)."""
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
