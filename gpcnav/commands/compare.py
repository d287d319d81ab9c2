"""Run several controllers on the very same episodes (scenario files or a seeded suite) and
write COMPARE.json (one EVAL document per controller, the episodes in the same order), a
Markdown table and a figure beside it (docs/peers.md)."""
from __future__ import annotations

import sys
from pathlib import Path

from ..controllers import check, parse_controller_list, spec_from_args
from .common import add_controller_arguments, add_suite_arguments, check_output_files, planner_config
from .evaluate import add_pool_arguments, controller_extra, eval_doc, pool_from_args, run_episodes, scenarios_from_args


def add_arguments(p):
    p.add_argument("scenarios", type=Path, nargs="*", help="scenario files")
    add_suite_arguments(p)
    add_controller_arguments(p, many=True)
    add_pool_arguments(p)
    p.add_argument("--out", type=Path, default=None,
                   help="write COMPARE.json here, with COMPARE.md (the table) and COMPARE.png (the figure) beside it")


def compare_document(specs, results, config, suite, seed, scenarios, extras, backend) -> dict:
    """``{"controllers": [EVAL, ...]}`` and what the episodes were."""
    docs = [eval_doc(spec, result, config, suite, seed, {**extra, "backend": backend})
            for spec, result, extra in zip(specs, results, extras)]
    return {"controllers": docs, "scenarios": [s.name for s in scenarios], "preset": config.name,
            "suite_spec": suite.describe() if suite else None}


def run(args) -> int:
    from casadi_gpc.io import save_figure, write_json, write_text

    from .compare_report import compare_figure, compare_table
    scenarios, suite = scenarios_from_args(args)
    pool = pool_from_args(args)
    config = planner_config(args)
    check_output_files(out=args.out)
    specs = [spec_from_args(args, name) for name in parse_controller_list(args.controllers)]
    robot = scenarios[0].robot
    for spec in specs:
        check(spec, config, robot)
    extras = [controller_extra(spec, config, robot) for spec in specs]
    results = run_episodes(scenarios, specs, config, pool, desc=f"{len(specs)} controllers")
    doc = compare_document(specs, results, config, suite, args.seed, scenarios, extras, args.backend)
    table = compare_table(doc)
    if args.out:
        write_json(args.out, doc)
        write_text(args.out.with_suffix(".md"), table + "\n")
        import matplotlib.pyplot as plt
        fig = compare_figure(doc)
        save_figure(fig, args.out.with_suffix(".png"), dpi=130)
        plt.close(fig)
    print(table, file=sys.stdout)
    return 0
