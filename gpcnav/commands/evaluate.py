"""Run many episodes (scenario files or a seeded suite) in parallel worker processes, or on
a Ray cluster, and write aggregate metrics (EVAL.json).

Each finished episode is kept on disk as it finishes (beside --out, in OUT.episodes/), so
the same command run again after an interruption, kill -9 included, reuses them and runs
only the rest; the document is the one an uninterrupted run writes (docs/evaluation.md)."""
from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

from ..controllers import ControllerSpec, check_scenarios, reads_planner_settings, spec_from_args
from ..errors import ControllerError, UsageError
from .common import (add_controller_arguments, add_suite_arguments, check_output_files, check_seed, check_writable_folder,
                     connected, planner_config, progress, recorded_changes, refuse_unread_changes, refuse_unused_fallback,
                     suite_from_args, for_pool, for_run, usable_cores)

_WORKER = {}


def add_arguments(p):
    p.add_argument("scenarios", type=Path, nargs="*", help="scenario files")
    add_suite_arguments(p)
    add_controller_arguments(p)
    add_pool_arguments(p)
    p.add_argument("--out", type=Path, default=None, help="write EVAL.json here")
    p.add_argument("--faults", default=None, metavar="SPEC",
                   help="inject faults into every episode, e.g. 'dropout_prob=0.1,outlier_prob=0.02'")
    add_resume_arguments(p)


def add_resume_arguments(p) -> None:
    """``--keep-episodes``: the finished episodes stay on disk after a successful run."""
    p.add_argument("--keep-episodes", action="store_true",
                   help="keep the finished episodes (OUT.episodes/ beside --out, or $GPCNAV_CACHE_DIR/episodes) "
                        "after the document is written; by default a successful run removes its own, and a run "
                        "that is stopped leaves them for the same command to reuse")


def add_pool_arguments(p) -> None:
    """``--workers``, ``--backend local|ray`` and ``--address``."""
    p.add_argument("--workers", type=int, default=usable_cores(),
                   help="worker processes, or the CPUs of a Ray instance started here (default: one a core this "
                        "process may use)")
    p.add_argument("--backend", choices=("local", "ray"), default="local",
                   help="local worker processes (default) or Ray (pip install 'gpcnav[distributed]')")
    p.add_argument("--address", default=None,
                   help="address of an existing Ray cluster (--backend ray; default: start a local one)")


def pool_from_args(args):
    """The :class:`casadi_gpc.pool.WorkerPool` the options give; bad values are one line."""
    from casadi_gpc.pool import WorkerPool
    if args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    if args.address and args.backend != "ray":
        raise UsageError("--address needs --backend ray")
    if args.backend == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise UsageError("--backend ray needs Ray: pip install 'gpcnav[distributed]'") from None
    return WorkerPool(args.workers, args.backend, args.address)


def _episode(index, job):
    """Worker: one episode; each controller is made once per worker and robot."""
    from scenarios.metrics import episode_metrics
    from scenarios.simulator import simulate

    from .. import controllers
    scenario, spec, config = job
    key = (spec, config, scenario.robot)
    if key not in _WORKER:
        _WORKER[key] = controllers.make(spec, config, scenario.robot)
    try:
        log = simulate(scenario, _WORKER[key], spec.label)
    except ControllerError as exc:  # a user's class raised: which episode, in its one line
        raise ControllerError(f"{exc} (in {scenario.source or scenario.name})") from None
    events = dict(log.events)
    if log.clipped_commands:  # RUN.json's own field; here among the events, so that EVAL and COMPARE count them
        events["clipped_commands"] = log.clipped_commands
    return index, (episode_metrics(log), log.compute_time_s, events)


def run_episodes(scenarios, specs, config, pool, desc: str = "episodes", store=None, keys=None,
                 log=None) -> list[tuple]:
    """Every controller of ``specs`` on every scenario, all episodes in one pool (episode by
    episode, each controller in turn, so that the controllers finish together).

    ``store``: an :class:`~gpcnav.commands.episode_store.EpisodeStore` with ``keys[k][i]``,
    the key of controller ``k`` on scenario ``i``: episodes found there are reused (``log``
    gets one line saying how many), the others kept there as they finish.

    Returns one ``(metrics, compute times, summed events)`` per spec, the metrics in the
    scenarios' order."""
    from dataclasses import replace
    results = [[None] * len(scenarios) for _ in specs]
    reused = 0
    if store is not None:
        for k in range(len(specs)):
            for i in range(len(scenarios)):
                results[k][i] = store.get(keys[k][i])
                reused += results[k][i] is not None
    jobs = [((k, i), (s, spec, config)) for i, s in enumerate(scenarios) for k, spec in enumerate(specs)
            if results[k][i] is None]
    total = len(scenarios) * len(specs)
    if reused and log:
        log(f"reused {reused} of {total} episodes finished earlier ({store.folder}); running the other {len(jobs)}")
    if jobs:
        _prepare_planner(jobs, pool)
        pool = replace(pool, workers=max(1, min(pool.workers, len(jobs))))
        for (k, i), result in progress(pool.imap_unordered(_episode, jobs), total=total, initial=reused, desc=desc,
                                       unit="ep"):
            results[k][i] = result
            if store is not None:
                store.put(keys[k][i], result)
    out = []
    for per_spec in results:
        metrics, times, events = [], [], {}
        for m, t, ev in per_spec:
            metrics.append(m)
            times.extend(t)
            for key, v in ev.items():
                events[key] = events.get(key, 0) + v
        out.append((metrics, times, events))
    return out


def _prepare_planner(jobs, pool) -> None:
    """Make every controller that runs the planner once here, before the workers start: a
    first run's compile (announced, casadi_gpc.solvers.compiling) happens once, in view, and
    not in every worker at once behind the progress bar. Local workers are forked afterwards
    and inherit the made controller."""
    from .. import controllers
    for _, (scenario, spec, config) in jobs:
        key = (spec, config, scenario.robot)
        if (spec.name == "gpc" or spec.mode == "gpc") and key not in _WORKER:
            _WORKER[key] = controllers.make(spec, config, scenario.robot)


def open_store(args, specs, config, extras, scenarios):
    """The episode store of this run (beside ``--out``) and every episode's key, after
    checking, before any work, that the store's folder can be written."""
    from .episode_store import EpisodeStore, episode_key, run_key, store_folder
    store = EpisodeStore(store_folder(args.out))
    check_writable_folder(store.folder, f"the finished episodes' folder {store.folder}")
    runs = [run_key(spec, config, extra) for spec, extra in zip(specs, extras)]
    return store, [[episode_key(r, s) for s in scenarios] for r in runs]


def close_store(args, store, keys) -> None:
    """After a successful run: remove its episodes (unless ``--keep-episodes``)."""
    if not args.keep_episodes:
        store.remove(key for per_spec in keys for key in per_spec)


def log_to_stderr(command: str):
    return lambda msg: print(f"gpcnav {command}: {msg}", file=sys.stderr, flush=True)


def evaluate(scenarios, kind, config, model=None, workers=1, desc="episodes", shield=None, passes=None,
             backend="local", address=None):
    """Run every scenario with one controller (a name or a :class:`ControllerSpec`); returns
    (metrics, all compute times, summed events)."""
    from casadi_gpc.pool import WorkerPool
    spec = kind if isinstance(kind, ControllerSpec) else ControllerSpec(kind, model, shield, passes)
    pool = WorkerPool(workers, backend, address)
    return run_episodes(scenarios, [spec], for_pool(config, pool), pool, desc)[0]


def parse_faults(spec: str | None):
    """``--faults NAME=VALUE,...`` as the ``[faults]`` table of a file, checked as one is (its
    ranges were not: ``dropout_prob=1.5`` ran, and NaN stopped the run after its episodes)."""
    from scenarios import Faults, ScenarioError
    from scenarios.loader import faults_from_table
    if spec is None:
        return None
    fields = {f for f in Faults.__dataclass_fields__}
    values = {}
    for item in spec.split(","):
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq or not key:
            raise UsageError(f"--faults takes NAME=VALUE,..., got {item!r}")
        if key not in fields:
            raise UsageError(f"--faults: unknown fault {key!r} (known: {', '.join(sorted(fields))})")
        if key in values:
            raise UsageError(f"--faults: {key} given twice")
        try:
            values[key] = int(value) if key == "delay_steps" else float(value)
        except ValueError:
            kind = "a whole number" if key == "delay_steps" else "a number"  # (1.5 was "needs a number")
            raise UsageError(f"--faults: {key} needs {kind}, got {value!r}") from None
    try:
        return faults_from_table(values, "--faults")
    except ScenarioError as exc:
        raise UsageError(str(exc)) from None


def scenarios_from_args(args) -> tuple[list, object]:
    """The scenarios the options name (files or a suite, faults applied) and the suite (or
    None); every bad value is a one-line error, before any work."""
    from dataclasses import replace

    from scenarios import load_scenario
    if bool(args.scenarios) == bool(args.suite):
        raise UsageError("give scenario files or --suite, not both and not neither")
    suite = suite_from_args(args)
    check_seed(args.seed)
    faults = parse_faults(getattr(args, "faults", None))
    if suite is not None:
        try:
            scenarios = suite.scenarios()
        except ValueError as exc:  # e.g. more movers than the crowd's geometry can place
            raise UsageError(f"--suite {suite.name}: {exc}") from None
    else:
        scenarios = [load_scenario(p) for p in args.scenarios]
        _say_repeated_files(args.scenarios, args.command)
    if faults is not None:
        _say_replaced_faults(scenarios, faults, args.command)
        scenarios = [replace(s, faults=faults) for s in scenarios]
    return scenarios, suite


def _say_replaced_faults(scenarios, faults, command: str) -> None:
    """One line on stderr when ``--faults`` replaces a file's own ``[faults]`` table (it did so
    without a word: a file's dropouts gone from its episode)."""
    from scenarios import Faults
    own = [s.source or s.name for s in scenarios if s.faults != Faults() and s.faults != faults]
    if own:
        more = f" and {len(own) - 3} more" if len(own) > 3 else ""
        print(f"gpcnav {command}: --faults replaces the [faults] table of {', '.join(map(str, own[:3]))}{more}",
              file=sys.stderr)


def _say_repeated_files(paths, command: str) -> None:
    """One line on stderr when a file is given more than once (``cases/*.toml cases/*.toml``): its
    episode runs, and counts in the rates and their bounds, once for each time (a file's episode is the
    same every time, its sensor noise seeded by the file)."""
    seen, repeated = {}, []
    for p in paths:
        try:
            key = Path(p).resolve()
        except OSError:
            key = Path(p)
        if key in seen and key not in repeated:
            repeated.append(key)
        seen[key] = p
    if repeated:
        more = f" and {len(repeated) - 3} more" if len(repeated) > 3 else ""
        names = ", ".join(str(seen[k]) for k in repeated[:3]) + more
        print(f"gpcnav {command}: {names} given more than once: each run counts, in the rates and their bounds, as "
              f"another episode", file=sys.stderr)


def controller_extra(spec: ControllerSpec, config, robot) -> dict:
    """What an EVAL document records of how a controller was made."""
    from .. import controllers
    extra = {"shield": spec.mode, "decision_passes": None, "solver": None}
    if spec.name == "nn":
        controller = controllers.make(replace(spec, shield="off"), config, robot)
        extra["decision_passes"] = 2 if controller.two_pass else 1
    elif spec.name == "gpc":
        extra["solver"] = config.solver
    else:
        bare = controllers.make(ControllerSpec(spec.name, shield="off"), config, robot)
        extra["controller_settings"] = controllers.describe(bare)
    return extra


def eval_doc(spec: ControllerSpec, result, config, suite, seed, extra: dict | None = None) -> dict:
    """The EVAL document of one controller's ``(metrics, times, events)``."""
    from scenarios.metrics import eval_document
    metrics, times, events = result
    # the controller's own rate (navground's peers decide every 0.1 s; it said the preset's 0.5)
    sample_time_s = ((extra or {}).get("controller_settings") or {}).get("sample_time_s", config.sample_time_s)
    return eval_document(spec.label, metrics, times, {
        "preset": config.name, "sample_time_s": sample_time_s, "suite": suite.name if suite else None,
        "seed": seed if suite else None, **({"suite_spec": suite.describe()} if suite else {}),
        "events": events, **recorded_changes(config, reads_planner_settings(spec)), "solve_lanes": config.solve_lanes,
        **(extra or {}),
    })


def run(args) -> int:
    from casadi_gpc.io import write_json
    scenarios, suite = scenarios_from_args(args)
    pool = pool_from_args(args)
    config = for_pool(for_run(planner_config(args), scenarios), pool)  # lanes: as many as the workers leave
    spec = spec_from_args(args)
    refuse_unused_fallback(args, [spec])
    check_scenarios(spec, config, scenarios)
    refuse_unread_changes([spec], config)
    check_output_files(inputs=[sc.source for sc in scenarios], models=[args.model, args.walls_model, args.crowd_model],
                       out=args.out)
    with connected(pool):
        extra = controller_extra(spec, config, scenarios[0].robot)
        store, keys = open_store(args, [spec], config, [extra], scenarios)
        faults = scenarios[0].faults if args.faults else None
        result = run_episodes(scenarios, [spec], config, pool, store=store, keys=keys, log=log_to_stderr("evaluate"))[0]
    doc = eval_doc(spec, result, config, suite, args.seed, {
        **extra, "faults": None if faults is None else faults.__dict__, "backend": args.backend,
        "workers": pool.workers})
    if args.out:
        write_json(args.out, doc)
    close_store(args, store, keys)
    ct = doc["compute_time_s"]
    print(f"{spec.label} [preset {config.name}] on {doc['episodes']} episodes: success "
          f"{doc['success_rate']:.3f}  collision {doc['collision_rate']:.3f}  timeout {doc['timeout_rate']:.3f}  "
          f"min clearance {doc['min_clearance_m']['min']:.3f} m (median {doc['min_clearance_m']['median']:.3f})  "
          f"decision median {ct['median'] * 1e3:.2f} ms (p99 {ct['p99'] * 1e3:.1f}, max {ct['max'] * 1e3:.1f}, "
          f"{ct.get('over_limit', 0)} over the sample time)  fallbacks {doc['fallbacks']}", file=sys.stdout)
    return 0
