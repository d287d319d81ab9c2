"""Run several controllers on the very same episodes (scenario files or a seeded suite) and
write COMPARE.json (one EVAL document per controller, the episodes in the same order), a
Markdown table and a figure beside it (docs/peers.md).

Each finished episode is kept on disk as it finishes (beside --out, in OUT.episodes/), so
the same command run again after an interruption, kill -9 included, reuses them and runs
only the rest (docs/evaluation.md)."""
from __future__ import annotations

import sys
from pathlib import Path

from ..controllers import check_controller_name, check_scenarios, parse_controller_list, spec_from_args
from ..errors import UsageError
from .common import (add_controller_arguments, add_suite_arguments, check_name_lengths, check_output_files,
                     check_regular_file, connected, for_pool, for_run, planner_changes, planner_config,
                     refuse_unread_changes, refuse_unused_fallback, same_file)
from .evaluate import (add_pool_arguments, add_resume_arguments, close_store, controller_extra, eval_doc, log_to_stderr,
                       open_store, pool_from_args, run_episodes, scenarios_from_args)


def add_arguments(p):
    p.add_argument("scenarios", type=Path, nargs="*", help="scenario files")
    add_suite_arguments(p)
    add_controller_arguments(p, many=True)
    add_pool_arguments(p)
    p.add_argument("--out", type=Path, default=None,
                   help="write COMPARE.json here, with COMPARE.md (the table) and COMPARE.png (the figure) beside it")
    add_resume_arguments(p)


def compare_document(specs, results, config, suite, seed, scenarios, extras, backend, workers: int) -> dict:
    """``{"controllers": [EVAL, ...]}`` and what the episodes were (``backend`` and ``workers``:
    the pool's, recorded in each EVAL)."""
    docs = [eval_doc(spec, result, config, suite, seed, {**extra, "backend": backend, "workers": workers})
            for spec, result, extra in zip(specs, results, extras)]
    return {"controllers": docs, "scenarios": [s.name for s in scenarios], "preset": config.name,
            "suite_spec": suite.describe() if suite else None}


def check_compare_outputs(out, inputs=(), models=()) -> None:
    """``--out`` and the table and figure beside it: each writable, none a folder, none one of
    the scenario files ``inputs``; ``--out`` not the ``--model`` file."""
    check_output_files(inputs=inputs, models=models, out=out)
    if out is not None:
        for beside in (out.with_suffix(".md"), out.with_suffix(".png")):
            what = "table" if beside.suffix == ".md" else "figure"
            check_name_lengths(beside, f"--out {out}: the {what} beside it")
            if beside.is_dir() or beside == out:
                raise UsageError(f"--out {out}: the {what} beside it, "
                                 f"{beside}, {'is a folder' if beside.is_dir() else 'would overwrite it'}")
            check_regular_file(beside, f"--out {out}: the {what} beside it, {beside},")
            if any(i and same_file(beside, Path(i)) for i in inputs):
                raise UsageError(f"--out {out}: the {what} beside it, {beside}, is one of the scenario files")


def run(args) -> int:
    from casadi_gpc.io import save_figure, write_json, write_text

    from .compare_report import compare_figure, compare_table, paired_table
    scenarios, suite = scenarios_from_args(args)
    pool = pool_from_args(args)
    config = for_pool(for_run(planner_config(args), scenarios), pool)  # lanes: as many as the workers leave
    check_compare_outputs(args.out, [sc.source for sc in scenarios], [args.model, args.walls_model, args.crowd_model])
    names = parse_controller_list(args.controllers)
    for name in names:  # (a name of no controller was said to be --controller's, an option not given)
        try:
            check_controller_name(name, "--controllers")
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    options = (("--model", args.model), ("--walls-model", args.walls_model), ("--crowd-model", args.crowd_model),
               ("--passes", args.passes))
    given = " and ".join(o for o, v in options if v is not None)
    if "nn" not in names and given:  # (dropped without a word)
        raise UsageError(f"{given}: for the controller nn, which --controllers {args.controllers} does not name")
    specs = [spec_from_args(args, name) for name in names]
    refuse_unused_fallback(args, specs)
    robot = scenarios[0].robot
    for spec in specs:
        check_scenarios(spec, config, scenarios)
    for spec in refuse_unread_changes(specs, config):  # run with the others, their documents say so
        print(f"gpcnav compare: {spec.label} does not read the planner settings given "
              f"({', '.join(sorted(planner_changes(config)))}); its document records them as planner_changes_unused",
              file=sys.stderr)
    with connected(pool):
        extras = [controller_extra(spec, config, robot) for spec in specs]
        store, keys = open_store(args, specs, config, extras, scenarios)
        results = run_episodes(scenarios, specs, config, pool, desc=f"{len(specs)} controllers", store=store,
                               keys=keys, log=log_to_stderr("compare"))
    doc = compare_document(specs, results, config, suite, args.seed, scenarios, extras, args.backend, pool.workers)
    table = compare_table(doc)
    paired = paired_table(doc)
    if paired:
        table += "\n\n" + paired
    if args.out:
        write_json(args.out, doc)
        write_text(args.out.with_suffix(".md"), table + "\n")
        import matplotlib.pyplot as plt
        fig = compare_figure(doc)
        save_figure(fig, args.out.with_suffix(".png"), dpi=130)
        plt.close(fig)
    close_store(args, store, keys)
    print(table, file=sys.stdout)
    return 0
