"""Run many episodes (scenario files or a seeded random suite) in parallel worker
processes and write aggregate metrics (EVAL.json)."""
from __future__ import annotations

import os
import sys
from pathlib import Path

from ..errors import UsageError
from .common import (add_controller_arguments, add_suite_arguments, check_seed, make_controller, planner_config,
                     progress, shield_mode, suite_from_args)

_WORKER = {}


def add_arguments(p):
    p.add_argument("scenarios", type=Path, nargs="*", help="scenario files")
    add_suite_arguments(p)
    add_controller_arguments(p)
    p.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="worker processes (default: all cores)")
    p.add_argument("--out", type=Path, default=None, help="write EVAL.json here")
    p.add_argument("--faults", default=None, metavar="SPEC",
                   help="inject faults into every episode, e.g. 'dropout_prob=0.1,outlier_prob=0.02'")


def _episode(index, job):
    """Worker: episode ``index``; the controller is built once per worker and robot."""
    from casadi_gpc.metrics import episode_metrics
    from casadi_gpc.simulator import simulate
    scenario, kind, config, model, shield, passes = job
    key = (kind, config, scenario.robot, str(model), shield, passes)
    if key not in _WORKER:
        _WORKER[key] = make_controller(kind, config, scenario.robot, model, shield, passes)
    controller = _WORKER[key]
    log = simulate(scenario, controller, kind)
    return index, (episode_metrics(log), log.compute_time_s, dict(log.events))


def parse_faults(spec: str | None):
    from scenarios import Faults
    if not spec:
        return None
    fields = {f for f in Faults.__dataclass_fields__}
    values = {}
    for item in spec.split(","):
        key, _, value = item.partition("=")
        key = key.strip()
        if key not in fields:
            raise UsageError(f"--faults: unknown fault {key!r} (known: {', '.join(sorted(fields))})")
        try:
            values[key] = int(value) if key == "delay_steps" else float(value)
        except ValueError:
            raise UsageError(f"--faults: {key} needs a number, got {value!r}") from None
    return Faults(**values)


def evaluate(scenarios, kind, config, model=None, workers=1, desc="episodes", shield=None, passes=None):
    """Run every scenario; returns (metrics, all compute times, summed events)."""
    from casadi_gpc.pool import WorkerPool
    jobs = [(i, (s, kind, config, model, shield, passes)) for i, s in enumerate(scenarios)]
    # the episodes come back as they finish; the metrics keep the scenarios' order
    pool = WorkerPool(min(workers, len(jobs)))
    results = [None] * len(jobs)
    for i, result in progress(pool.imap_unordered(_episode, jobs), total=len(jobs), desc=desc, unit="ep"):
        results[i] = result
    metrics, times, events = [], [], {}
    for m, t, ev in results:
        metrics.append(m)
        times.extend(t)
        for k, v in ev.items():
            events[k] = events.get(k, 0) + v
    return metrics, times, events


def run(args) -> int:
    from dataclasses import replace

    from casadi_gpc.metrics import eval_document
    from scenarios import load_scenario
    from casadi_gpc.io import write_json
    if bool(args.scenarios) == bool(args.suite):
        raise UsageError("give scenario files or --suite, not both and not neither")
    suite = suite_from_args(args)
    if args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    check_seed(args.seed)
    config = planner_config(args)
    faults = parse_faults(args.faults)
    if suite is not None:
        scenarios = suite.scenarios()
    else:
        scenarios = [load_scenario(p) for p in args.scenarios]
    if faults is not None:
        scenarios = [replace(s, faults=faults) for s in scenarios]
    passes = None
    if args.controller == "nn":
        # refuse a bad model before any work; the passes it runs with
        passes = 2 if make_controller("nn", config, scenarios[0].robot, args.model, "off", args.passes).two_pass else 1
    shield = shield_mode(args)
    metrics, times, events = evaluate(scenarios, args.controller, config, args.model, args.workers, shield=shield,
                                      passes=passes)
    doc = eval_document(args.controller, metrics, times, {
        "preset": config.name, "sample_time_s": config.sample_time_s, "suite": args.suite,
        "seed": args.seed if args.suite else None, **({"suite_spec": suite.describe()} if suite else {}),
        "events": events,
        "faults": None if faults is None else faults.__dict__, "shield": shield, "decision_passes": passes,
        "solver": config.solver if args.controller == "gpc" else None,
    })
    if args.out:
        write_json(args.out, doc)
    ct = doc["compute_time_s"]
    print(f"{args.controller} [preset {config.name}] on {doc['episodes']} episodes: success "
          f"{doc['success_rate']:.3f}  collision {doc['collision_rate']:.3f}  timeout {doc['timeout_rate']:.3f}  "
          f"min clearance {doc['min_clearance_m']['min']:.3f} m (median {doc['min_clearance_m']['median']:.3f})  "
          f"decision median {ct['median'] * 1e3:.2f} ms  fallbacks {doc['fallbacks']}", file=sys.stdout)
    return 0
