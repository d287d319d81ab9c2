"""The solver benchmark: record the control problems of a closed-loop GPC run on a scenario
(the paper's Fig. 7.2 by default), solve them all with every solver in one process, and
write BENCH.json, a chart of the time per solve and a table."""
from __future__ import annotations

import sys
from pathlib import Path

from ..errors import UsageError, comma_items
from .common import add_preset_arguments, check_output_files, for_run, planner_config, progress

DEFAULT_SCENARIO = "fig7_2_crossing"


def _solver_names() -> tuple[str, ...]:
    """The solvers' names; none without CasADi (the parser of every subcommand is built at
    start, and the deployed network's commands run without CasADi: ``bench`` then says so
    when run)."""
    try:
        from casadi_gpc.solvers import SOLVER_NAMES
    except ImportError:
        return ()
    return SOLVER_NAMES


def add_arguments(p):
    SOLVER_NAMES = _solver_names()
    p.add_argument("scenario", type=Path, nargs="?", default=None,
                   help=f"scenario file (TOML); default the paper's {DEFAULT_SCENARIO}")
    p.add_argument("--solvers", default=",".join(SOLVER_NAMES), metavar="LIST",
                   help=f"comma-separated solvers (default all: {','.join(SOLVER_NAMES)}); "
                        "ipopt-warm, the reference, is always run")
    p.add_argument("--out", type=Path, default=None, help="write BENCH.json here")
    p.add_argument("--plot", type=Path, default=None, help="write the time-per-solve chart (PNG) here")
    p.add_argument("--no-gpc-rows", action="store_true",
                   help="leave out the full GPC decision rows (estimation + multi-start solves)")
    p.add_argument("--model", type=Path, default=None,
                   help="ONNX network for the network rows and --controller nn (default: the one shipped for "
                        "--preset)")
    p.add_argument("--no-nn-rows", action="store_true", help="leave out the network rows")
    p.add_argument("--controller", action="append", default=[], metavar="NAME",
                   help="also time this controller's full decision on the same recorded observations (repeatable; "
                        "gpc, nn, orca, hrvo, social_force, mppi, the baselines stand and blind, or MODULE:CLASS; "
                        "docs/peers.md)")
    p.add_argument("--shield", action="store_true",
                   help="the --controller rows behind the safety check layer (casadi_gpc.safety.Shield)")
    p.add_argument("--crowd-movers", type=int, default=10, metavar="N",
                   help="the planner's decision is also measured on a crowd scene: circle-crossing, N orca "
                        "movers, seed 1, its first episode (default 10; 0: none)")
    p.add_argument("--crowd-episodes", type=int, default=None, metavar="K",
                   help="the GPC's and the deployed network's decisions are also pooled over the crowd scene's "
                        "first K episodes, the two run one after the other on each (a p99 of one crossing, "
                        "about 45 decisions, is its largest but one; default 10; 0: not pooled)")
    add_preset_arguments(p)


def controller_policies(args, config, robot) -> list:
    """The ``--controller`` rows: ``(label, make_policy)`` pairs from the controller registry,
    each refused in one line before any work if it cannot be made. A controller whose
    sample time is not the planner's is given the recorded observations all the same (its
    decision time is what the row is for; its obstacle filter then steps at its own T). ``nn``
    runs ``--model`` where given (it ran the shipped network under the same label)."""
    from ..controllers import ControllerSpec, check, make
    entries = []
    for name in dict.fromkeys(getattr(args, "controller", []) or []):
        model = getattr(args, "model", None) if name == "nn" else None
        spec = ControllerSpec(name, model, shield="on" if args.shield else None)
        check(spec, config, robot)
        entries.append((spec.label, lambda spec=spec: make(spec, config, robot)))
    return entries


def extra_policies(args, config, robot) -> list:
    """Policies to time beside the solvers: ``(name, make_policy)`` pairs, see
    :func:`gpcnav.benchmarks.solvers.policy_rows`. The network policies (numpy, torch, onnxruntime)
    are timed on the features the ``onnxpolicy`` row recorded (:func:`network_rows`)."""
    if getattr(args, "no_nn_rows", False):
        return controller_policies(args, config, robot)
    try:
        from nn_export.training.bench_rows import policy_entries
        entries, args._nn_recorder = policy_entries(config, robot, args.model)
    except (ImportError, FileNotFoundError, ValueError) as exc:
        raise UsageError(f"network rows: {exc} (use --no-nn-rows to leave them out)") from None
    return entries + controller_policies(args, config, robot)


def network_rows(args, doc) -> None:
    """Add the network calls (onnxruntime, numpy, torch: inside the policy's decisions) and the
    network speedups."""
    recorder = getattr(args, "_nn_recorder", None)
    if recorder is None or not recorder.observations:
        return
    from nn_export.training.bench_rows import forward_rows, network_speedups, unmeasured_reason
    path, robot = recorder.policy.model_info["path"], recorder.policy.robot
    rows = forward_rows(path, recorder.observations, robot=robot)
    if not rows:  # every decision by a side network (walls, crowd): said, not rows of 0 ms
        doc["network_rows_not_measured"] = unmeasured_reason(path, recorder.observations, robot)
    doc["results"] += rows
    doc["speedup"].update(network_speedups(doc["results"], doc["chosen"]["name"], doc["reference"]))
    doc["network"] = recorder.policy.model_info


def network_decisions(args, doc, config, scenarios) -> None:
    """The network as deployed (behind the planner-free check, the controller registry's
    ``nn``: numpy, onnxruntime and numba) closed loop on the crowd scene(s):
    ``doc["network_decisions"]``, and its speed-up over the GPC's decision on the same scene in
    this run, median, p99 and max (``doc["deployed_vs_gpc"]``)."""
    if getattr(args, "no_nn_rows", False) or not scenarios:
        return
    from gpcnav.benchmarks.decisions import deployed_against_gpc, policy_decision_run

    from ..controllers import ControllerSpec, make
    spec = ControllerSpec("nn", model=args.model)
    doc["network_decisions"] = [policy_decision_run(sc, spec.label, make(spec, config, sc.robot)) for sc in scenarios]
    doc["deployed_vs_gpc"] = deployed_against_gpc(doc.get("decisions", []), doc["network_decisions"])


def crowd_suite(movers: int, episodes: int):
    """The bench's crowd scene: circle-crossing with ``movers`` ORCA walkers, seed 1, its first
    ``episodes`` episodes (the first alone has the decision rows)."""
    from scenarios import Suite
    return Suite("circle-crossing", episodes, 1, movers, "orca")


CROWD_EPISODES = 10
"""``--crowd-episodes``' default: a p99 over some 450 decisions."""


def pooled_crowd(args, doc, config, say) -> None:
    """The crowd scene's first ``--crowd-episodes`` episodes, the GPC (unless ``--no-gpc-rows``)
    and the deployed network (unless ``--no-nn-rows``) on each, pooled
    (:func:`gpcnav.benchmarks.decisions.crowd_decisions`): ``doc["crowd_decisions"]``."""
    if not args.crowd_movers or not args.crowd_episodes or (args.no_gpc_rows and args.no_nn_rows):
        return
    from gpcnav.benchmarks.decisions import crowd_decisions

    from ..controllers import ControllerSpec, make
    suite = crowd_suite(args.crowd_movers, args.crowd_episodes)
    spec = ControllerSpec("nn", model=args.model)
    say(f"the GPC's and the deployed network's decisions over {args.crowd_episodes} crossings of {args.crowd_movers} "
        f"walkers")
    doc["crowd_decisions"] = {
        "suite": {"name": "circle-crossing", "movers": args.crowd_movers, "behaviour": "orca", "seed": 1,
                  "episodes": args.crowd_episodes},
        **crowd_decisions([suite.scenario(i) for i in range(args.crowd_episodes)],
                          None if args.no_gpc_rows else config,
                          None if args.no_nn_rows else (lambda sc: make(spec, config, sc.robot)),
                          progress=lambda it: progress(it, desc="crowd episodes", unit="ep"))}  # (15 s by default)


def pooled_summary(pooled: dict) -> list[str]:
    """The lines ``gpcnav bench`` prints of ``doc["crowd_decisions"]``."""
    s = pooled["suite"]
    lines = [f"over the first {s['episodes']} crossings of circle-crossing, {s['movers']} {s['behaviour']} walkers, "
             f"seed {s['seed']} (the two run one after the other on each):"]
    for name, what, unit, scale, digits in (("gpc", "the GPC behind its check", "ms", 1e3, 2),
                                            ("nn", "the deployable decision", "us", 1e6, 0)):
        row = pooled.get(name)
        if row is None:
            continue
        t = {k: f"{row['time_s'][k] * scale:.{digits}f}" for k in ("median", "p99", "max")}
        outcomes = ", ".join(f"{v} {k}" for k, v in row["outcomes"].items())
        lines.append(f"  {what}: {row['decisions']} decisions, median {t['median']} {unit} (p99 {t['p99']}, max "
                     f"{t['max']}); {outcomes}; {row['interventions']} interventions")
        if row.get("parts_s"):
            lines.append("    its parts (medians / p99s): " + ", ".join(
                f"{k} {row['parts_s'][k] * 1e6:.0f} / {row['parts_p99_s'][k] * 1e6:.0f} us" for k in row["parts_s"]))
    r = pooled.get("gpc_over_nn")
    if r:
        lines.append(f"  the GPC's decision over the deployable one: median {r['median']:.1f}x, p99 {r['p99']:.1f}x, "
                     f"max {r['max']:.1f}x")
    return lines


def parse_solvers(text: str) -> list[str]:
    from casadi_gpc.solvers import canonical_name
    names = comma_items(text, "--solvers")
    if not names:
        raise UsageError("--solvers: give at least one solver")
    try:
        return list(dict.fromkeys(canonical_name(n) for n in names))
    except ValueError as exc:
        raise UsageError(f"--solvers: {exc}") from None


def run(args) -> int:
    if not _solver_names():
        raise UsageError("bench times the GPC beside the network: it needs CasADi (pip install -e .), which this "
                         "Python cannot import")
    from gpcnav.benchmarks.bench_report import bench_figure, format_table
    from gpcnav.benchmarks.solvers import run_bench
    from scenarios import PAPER_DIR, load_scenario

    from casadi_gpc.io import save_figure, write_json
    solvers = parse_solvers(args.solvers)
    if args.model is not None and args.no_nn_rows and "nn" not in args.controller:  # (dropped without a word)
        raise UsageError(f"--model {args.model}: for the network rows, which --no-nn-rows leaves out, and "
                         f"--controller nn")
    if args.shield and not args.controller:  # (it ran the whole bench, the option doing nothing)
        raise UsageError("--shield puts the --controller rows behind the check layer: give --controller NAME")
    check_output_files(inputs=[args.scenario], models=[args.model], out=args.out, plot=args.plot)
    config = planner_config(args)
    scenario = load_scenario(args.scenario if args.scenario is not None else PAPER_DIR / f"{DEFAULT_SCENARIO}.toml")
    if scenario.duration_s < config.sample_time_s:
        raise UsageError(f"{scenario.source or scenario.name}: duration_s {scenario.duration_s:g} s is shorter than one "
                         f"sample ({config.sample_time_s:g} s): one decision cut short, nothing to time")

    def say(msg):
        print(msg, file=sys.stderr, flush=True)

    if args.crowd_movers < 0:
        raise UsageError(f"--crowd-movers must be 0 or more, got {args.crowd_movers}")
    if args.crowd_episodes is not None and args.crowd_episodes < 0:
        raise UsageError(f"--crowd-episodes must be 0 or more, got {args.crowd_episodes}")
    if args.crowd_episodes and (not args.crowd_movers or (args.no_gpc_rows and args.no_nn_rows)):  # (ignored)
        left_out = "--crowd-movers 0 leaves" if not args.crowd_movers else "--no-gpc-rows and --no-nn-rows leave"
        raise UsageError(f"--crowd-episodes {args.crowd_episodes}: pools the GPC's and the network's decisions on "
                         f"the crowd scene, which {left_out} out")
    args.crowd_episodes = CROWD_EPISODES if args.crowd_episodes is None else args.crowd_episodes
    crowd = [] if not args.crowd_movers else [crowd_suite(args.crowd_movers, 1).scenario(0)]
    # the planner as evaluate runs these scenes: wall slots where one has walls, the crowd NLP
    # where one has more movers than the preset's slots
    config = for_run(config, [scenario, *crowd])
    doc = run_bench(scenario, config, solvers, policies=extra_policies(args, config, scenario.robot),
                    gpc_rows=not args.no_gpc_rows,
                    progress=lambda it: progress(it, desc="problems", unit="problem"), say=say,
                    decision_scenarios=crowd)
    network_rows(args, doc)
    network_decisions(args, doc, config, crowd)
    pooled_crowd(args, doc, config, say)
    if args.out:
        write_json(args.out, doc)
    if args.plot:
        import matplotlib.pyplot as plt
        fig = bench_figure(doc)
        save_figure(fig, args.plot, dpi=130)
        plt.close(fig)
    ch = doc["chosen"]
    print(f"{doc['scenario']} [preset {doc['preset']}, H={doc['horizon']}, T={doc['sample_time_s']} s]: "
          f"{doc['problems']} step problems (+{doc['multistart_problems']} multistart solves, "
          f"reported under 'multistart' in BENCH.json)" + (
              "; posed on " + " and ".join(f"{n['problems']} on the NLP with {n['moving_slots']} mover slots"
                                            for n in doc["nlps"]) if len(doc["nlps"]) > 1 else ""))
    print(format_table(doc))
    if any(r["name"] == "onnxruntime" for r in doc["results"]):
        from nn_export.training.bench_rows import network_summary
        print(network_summary(doc["results"]))
    elif doc.get("network_rows_not_measured"):
        print(doc["network_rows_not_measured"])
    for d in doc["decisions"]:
        t, cv = d["time_s"], d["candidates_vs_multistart"]
        print(f"decision on {d['scenario']} ({d['movers']} movers, closed loop, behind the check layer): median "
              f"{t['median'] * 1e3:.3f} ms (p95 {t['p95'] * 1e3:.2f}, p99 {t.get('p99', t['p95']) * 1e3:.2f}, "
              f"max {t['max'] * 1e3:.2f}) = "
              f"{d['decision_over_warm_solve']:.1f} warm solves of {d['single_warm_solver']}; "
              f"{d['solves_per_decision']:.2f} "
              f"solves per decision, the fixed guesses at {d['full_multistart_share']:.0%} of them; persistent "
              f"candidates as good as the full multi-start at {cv['as_good_rate']:.1%} of {cv['steps']} steps "
              f"({cv['solves_per_step']['persistent']:.2f} against {cv['solves_per_step']['multistart']:.2f} solves "
              f"a step)")
    for d in doc.get("network_decisions", []):
        t = d["time_s"]
        print(f"deployable decision on {d['scenario']} ({d['movers']} movers, closed loop, {d['controller']}: the "
              f"network behind the planner-free check, numpy + onnxruntime + numba): median {t['median'] * 1e6:.0f} us "
              f"(p95 {t['p95'] * 1e6:.0f}, p99 {t['p99'] * 1e6:.0f}, max {t['max'] * 1e6:.0f}); "
              f"{d['interventions']} interventions in {d['decisions']} decisions, {d['outcome']}")
        for key, label in (("parts_s", "medians"), ("parts_p99_s", "p99s")):
            parts = d.get(key)
            if parts:
                print(f"  its parts ({label}): " + ", ".join(
                    f"{what} {parts[k] * 1e6:.0f} us" for k, what in (
                        ("estimation", "estimation (the filters' updates, desired poses, forecasts)"),
                        ("network", "features and network"), ("check", "check"), ("rest", "the rest"))))
    for r in doc.get("deployed_vs_gpc", []):
        print(f"the GPC's decision over the deployable one on {r['scenario']}, this run: median "
              f"{r['speedup_median']:.1f}x, p99 {r['speedup_p99']:.1f}x, max {r['speedup_max']:.1f}x")
    if "crowd_decisions" in doc:
        print("\n".join(pooled_summary(doc["crowd_decisions"])))
    print(f"chosen: {ch['name']}  median {ch['median_time_s'] * 1e3:.3f} ms  "
          f"{ch['speedup_vs_reference']:.1f}x faster than {doc['reference']}  success {ch['success_rate']:.1%}  "
          f"as good as {doc['reference']} on {ch['as_good_as_reference_rate']:.1%} of the problems"
          + (f" (the rule's pick on this scene; the planner solves with its preset's {config.solver})"
             if ch["name"] != config.solver else ""))
    return 0
