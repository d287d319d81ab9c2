"""On-policy data (DAgger, and DART when the GPC itself drives): a driver runs episodes, every
situation it visits is labelled by the GPC, and the samples are appended to a dataset as a
part of their own.

Two kinds of labels (:attr:`OnPolicyOptions.labels`):

- ``cold`` (the default, and every shipped network before the walls network): each situation
  solved afresh from the planner's fixed guesses (:class:`~nn_export.training.labels.Labeller`),
  the answer of a planner that has just been switched on there;
- ``closed-loop``: the answer of a planner that has driven along (a *shadow* GPC, bare, fed
  the same observations as the driver from the episode's start, so its filters, reference
  clock and kept candidates are what they would be in closed loop). This is what the closed
  loop the network imitates actually commands. The two differ where the planner's kept
  candidates hold it to a choice the cold multi-start does not find or does not prefer: on the
  ``corner`` suite's GPC-driven episodes the cold label was more than 0.1 m/s from the GPC's
  own command in 18 % of the situations, 30 % with a person within 2 m (docs/buildings.md).
  The shadow's fallbacks (no converged plan) are not labelled, and counted as not converged.
  Measured on the walls network, the networks trained on them were worse than on cold labels
  (as many collisions, many more timeouts; docs/buildings.md, "The network reads walls"):
  the shipped ones are trained on cold labels.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.pool import WorkerPool
from casadi_gpc.robot import RobotParams, RobotState

from ...runtime.layouts import FeatureLayout, layout_from_dict
from ...runtime.tracker import SituationTracker
from ..labels import GUESS_NAMES, Label, Labeller
from .labelling import ShardBuilder, label_situations, labeller_for, new_stats
from .shards import (MANIFEST, locked, manifest_document, merge_stats, read_manifest, shard_name, stats_summary,
                     write_manifest, write_shard)
from .spec import SHARD_STRIDE, DatasetMismatch, digest

__all__ = ["OnPolicyOptions", "Recorder", "LABEL_KINDS", "closed_loop_label", "perturb_start", "collect_on_policy",
           "collect_on_policy_parallel", "append_part"]

LABEL_KINDS = ("cold", "closed-loop")


class Recorder:
    """Wraps a policy: passes decisions through and records the situation at every sample,
    built by the same :class:`SituationTracker` the deployed policy uses.

    With ``noise_mps`` > 0 the wheel speeds the policy asks for are perturbed by independent
    N(0, noise_mps) before they are applied (DART, Laskey et al. 2017): the expert drives,
    but the recorded states spread around its path the way a learner's errors spread them.
    The labels are not affected: every recorded situation is labelled afresh by the GPC.
    The number of perturbed decisions is counted (``counters["driving_noise_applied"]``)."""

    def __init__(self, policy, config: PlannerConfig, noise_mps: float = 0.0, seed: int = 0, shadow=None):
        self.policy = policy
        self.shadow = shadow
        """The planner that labels each situation in closed loop (None: cold labels later)."""
        self.tracker = SituationTracker(config)
        self.sample_time_s = policy.sample_time_s
        self.situations = []
        self.noise_mps = float(noise_mps)
        self._rng = np.random.default_rng(seed)
        self._perturbed = 0

    @property
    def counters(self):
        c = dict(getattr(self.policy, "counters", {}))
        if self.noise_mps > 0:
            c["driving_noise_applied"] = self._perturbed
        return c

    def reset(self) -> None:
        self.policy.reset()
        if self.shadow is not None:
            self.shadow.reset()
        self.tracker.reset()
        self.situations = []
        self._perturbed = 0

    def decide(self, obs):
        sit = self.tracker.update(obs)
        self.situations.append(sit if self.shadow is None else (sit, closed_loop_label(self.shadow.decide(obs))))
        dec = self.policy.decide(obs)
        if self.noise_mps > 0:
            e = self._rng.normal(0.0, self.noise_mps, 2)
            dec = replace(dec, v_right_mps=float(dec.v_right_mps + e[0]), v_left_mps=float(dec.v_left_mps + e[1]))
            self._perturbed += 1
        return dec


def closed_loop_label(decision) -> Label:
    """The :class:`~nn_export.training.labels.Label` of a GPC's decision in closed loop: its
    plan's first step and whole plan, cost, winning candidate and iterations; not converged
    where the planner fell back. The candidates' costs are not known (NaN)."""
    H = None if decision.planned_wheels_mps is None else len(decision.planned_wheels_mps)
    costs = np.full(len(GUESS_NAMES), np.nan)
    info = decision.info
    if decision.fallback or H is None:
        n = H or 1
        return Label(False, np.full(2, np.nan), np.full((n, 2), np.nan), float("nan"), decision.reason or "fallback",
                     "", -1, costs, float(info.get("solve_time_s", 0.0)), int(info.get("candidates", 0)),
                     str(info.get("solver", "")))
    plan = np.asarray(decision.planned_wheels_mps, dtype=float)
    return Label(True, plan[0].copy(), plan, float(decision.cost), "closed-loop", str(decision.reason),
                 int(info.get("iterations", -1)), costs, float(info.get("solve_time_s", 0.0)),
                 int(info.get("candidates", 0)), str(info.get("solver", "")))


def perturb_start(scenario, rng: np.random.Generator, lateral_m: float, heading_rad: float):
    """``scenario`` with the robot's start moved sideways by U(-lateral_m, lateral_m) from the
    path and turned by U(-heading_rad, heading_rad) (recovering starts, as in Fig. 7.3)."""
    if lateral_m <= 0 and heading_rad <= 0:
        return scenario
    s0 = scenario.robot_start
    off = rng.uniform(-lateral_m, lateral_m)
    dh = rng.uniform(-heading_rad, heading_rad)
    start = RobotState(s0.x_m - off * math.sin(s0.heading_rad), s0.y_m + off * math.cos(s0.heading_rad),
                       s0.heading_rad + dh)
    return replace(scenario, robot_start=start)


@dataclass(frozen=True)
class OnPolicyOptions:
    """One on-policy round: who labels, what is kept, how the driver is perturbed."""

    config: PlannerConfig
    """The planner whose situations are labelled (its sample time must be the driver's)."""
    layout: FeatureLayout
    """The dataset's feature layout."""
    solver: str | None = None
    """The labelling solver (None: :func:`~nn_export.training.labels.label_solver`)."""
    robot: RobotParams = field(default_factory=RobotParams)
    mirror: bool = True
    """Add the mirror image of every situation as a second sample."""
    mirror_check_every: int = 0
    """Solve the mirrored situation for real for every this-many-th situation (0: never)."""
    noise_mps: float = 0.0
    """Std of the N(0, noise_mps) added to each applied wheel speed, m/s (DART; see
    :class:`Recorder`)."""
    noise_seed: int = 0
    """Seed of that noise."""
    id_base: int = 0
    """The first situation id (a part's ids: ``round * PART_STRIDE`` and up)."""
    tie_margin: float | None = None
    """The labels' near-tie margin (:mod:`nn_export.training.ties`); None: the planner's choice."""
    labels: str = "cold"
    """``cold``: each situation solved afresh from the fixed guesses; ``closed-loop``: the
    answer of a GPC kept in step with the episode (the module docstring)."""

    def __post_init__(self):
        if self.labels not in LABEL_KINDS:
            raise ValueError(f"labels must be one of {', '.join(LABEL_KINDS)}, got {self.labels!r}")
        if self.labels == "closed-loop" and self.tie_margin is not None:
            raise ValueError("a near-tie margin applies to cold labels, not closed-loop ones")


def collect_on_policy(policy, scenarios, options: OnPolicyOptions, labeller: Labeller | None = None
                      ) -> tuple[dict, dict]:
    """DAgger: run ``policy`` (anything with ``decide(observation)``) on every scenario,
    label every situation it visits with the GPC, and return ``(arrays, stats)`` in the
    shard format (``stats["episodes"]`` lists each episode's outcome). ``labeller``: one
    already built for ``options`` (else one is built here)."""
    config, layout = options.config, options.layout
    if abs(policy.sample_time_s - config.sample_time_s) > 1e-12:
        raise ValueError(f"policy sample time {policy.sample_time_s} s != planner's {config.sample_time_s} s")
    t0 = time.perf_counter()
    labeller = labeller or Labeller(config, options.robot, options.solver, tie_margin=options.tie_margin)
    situations, episodes = _drive(policy, scenarios, options)
    n = len(situations) * (2 if options.mirror else 1)
    builder = ShardBuilder(n, layout.size, config.horizon)
    stats = new_stats()
    # a closed-loop label is no cold multi-start's: the cold mirror check does not apply to it
    check_every = options.mirror_check_every if options.labels == "cold" else 0
    label_situations(builder, stats, iter(situations), layout, labeller, options.mirror, check_every,
                     options.id_base)
    arrays = {k: (v[: builder.k] if isinstance(v, np.ndarray) else v) for k, v in builder.arrays().items()}
    stats["episodes"] = episodes
    stats["elapsed_s"] = time.perf_counter() - t0  # driving and labelling (a round's part recorded 0.0)
    return arrays, stats


def _drive(policy, scenarios, options: OnPolicyOptions) -> tuple[list, list[dict]]:
    """Run ``policy`` on every scenario: the situations it visited, and each episode's outcome."""
    from scenarios.simulator import simulate
    shadow = _shadow(options.config, options.robot) if options.labels == "closed-loop" else None
    recorder = Recorder(policy, options.config, options.noise_mps, options.noise_seed, shadow)
    situations, episodes = [], []
    for sc in scenarios:
        log = simulate(sc, recorder, "on-policy")
        situations += recorder.situations
        episodes.append({"scenario": sc.name, "outcome": log.outcome, "steps": len(log.decisions),
                         "min_clearance_m": float(log.min_clearance_m),
                         "noise_applied": int(log.events.get("driving_noise_applied", 0))})
    return situations, episodes


_SHADOWS: dict = {}
"""The shadow planner of each worker process (closed-loop labels), built on first use."""


def _shadow(config: PlannerConfig, robot: RobotParams):
    """This process's bare GPC for ``(config, robot)``, built once (reset by the recorder
    before every episode)."""
    key = (config, robot)
    if key not in _SHADOWS:
        from casadi_gpc.planner.gpc import GPCController
        _SHADOWS[key] = GPCController(config, robot)
    return _SHADOWS[key]


_POLICIES: dict = {}
"""The driver of each worker process, built on first use."""


def _on_policy_chunk(policy_factory, scenarios, options: OnPolicyOptions, chunk: int):
    """Worker task: one chunk of episodes (driver and labeller built once per process); its
    situation ids start at ``chunk`` shard strides above the round's, its noise seed is the
    round's first id plus ``chunk``."""
    key = repr(policy_factory)
    if key not in _POLICIES:
        _POLICIES[key] = policy_factory()
    chunk_options = replace(options, id_base=options.id_base + chunk * SHARD_STRIDE,
                            noise_seed=options.id_base + chunk)
    labeller = labeller_for(options.config, options.robot, options.solver, options.tie_margin)
    return (chunk, *collect_on_policy(_POLICIES[key], scenarios, chunk_options, labeller))


def collect_on_policy_parallel(policy_factory, scenarios, options: OnPolicyOptions, pool: WorkerPool = WorkerPool(),
                               progress=None) -> tuple[dict, dict]:
    """:func:`collect_on_policy` over the worker ``pool``, in chunks of episodes.
    ``policy_factory`` is a picklable callable returning the driver (e.g.
    ``functools.partial(OnnxPolicy, path)``). ``progress``: an optional ``tqdm``-like
    factory. Returns the arrays of all chunks, in episode order, and the merged stats."""
    scenarios = list(scenarios)
    size = max(1, -(-len(scenarios) // max(1, 4 * pool.workers)))
    chunks = [scenarios[i:i + size] for i in range(0, len(scenarios), size)]
    if len(chunks) > SHARD_STRIDE // 1000:
        raise ValueError(f"too many chunks ({len(chunks)}); use fewer episodes per round")
    tasks = [(policy_factory, c, options, i) for i, c in enumerate(chunks)]
    results = {}
    pending = pool.imap_unordered(_on_policy_chunk, tasks)
    bar = progress(total=len(scenarios), unit="ep") if progress else None
    try:
        for i, arrays, stats in pending:
            results[i] = (arrays, stats)
            if bar is not None:
                bar.update(len(chunks[i]))
    finally:
        if bar is not None:
            bar.close()
    ordered = [results[i] for i in range(len(chunks))]
    arrays = {k: np.concatenate([a[k] for a, _ in ordered]) for k in ordered[0][0]}
    stats, episodes = new_stats(), []
    for _, st in ordered:
        episodes += st["episodes"]
        merge_stats(stats, {k: v for k, v in st.items() if k != "episodes"})
    stats["episodes"] = episodes
    return arrays, stats


def append_part(out_dir, part: str, arrays: dict, stats: dict, info: dict | None = None) -> dict:
    """Add ``arrays`` (shard format) to a dataset as part ``part`` (e.g. ``dagger1``), written
    whole or not at all; the manifest's ``samples`` grows by their number."""
    out = Path(out_dir)
    if not part.replace("_", "").isalnum() or part == "offpolicy" or part.startswith("shard"):
        raise ValueError(f"bad part name {part!r}")
    with locked(out):
        man = read_manifest(out)
        if part in man.get("parts", {}):
            raise DatasetMismatch(f"{out} already has a part {part!r}")
        lay = layout_from_dict(man["feature_layout"])
        if arrays["features"].shape[1:] != (lay.size,):
            raise ValueError(f"features have {arrays['features'].shape[1:]} columns, the dataset {lay.size}")
        name = shard_name(0, part)
        stats = {k: v for k, v in stats.items() if k != "episodes"} | {"episodes": stats.get("episodes", [])}
        write_shard(out / name, arrays, digest(info or {}), stats)
        parts = dict(man["parts"])
        parts[part] = {"kind": "on-policy (DAgger)", "samples": int(len(arrays["labels"])), "shards": [name],
                       "complete": True, "info": info or {}, "stats": stats_summary(
                           {k: v for k, v in stats.items() if k != "episodes"}),
                       "episodes": len(stats.get("episodes", []))}
        base = {k: v for k, v in man.items() if k not in ("samples", "shards", "parts")}
        doc = manifest_document(out, parts, base)
        doc["complete"] = all(p.get("complete", False) for p in parts.values())
        return write_manifest(out / MANIFEST, doc)
