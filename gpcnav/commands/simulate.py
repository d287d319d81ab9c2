"""Run one closed-loop episode of a scenario file and write RUN.json, a plot, a GIF."""
from __future__ import annotations

import sys
from pathlib import Path

from ..controllers import ControllerSpec, check, describe, make, reads_planner_settings, spec_from_args
from .common import (add_controller_arguments, check_output_files, check_seed, planner_config, for_pool, for_run,
                     progress, recorded_changes, refuse_unread_changes, refuse_unused_fallback)

REFERENCE_POINTS = 20001
"""The most points of RUN.json's ``reference_path`` (a point every 0.1 m up to 2 km of path, then
farther apart): a path of 1e9 m, which a scenario file may have, asked for 1e10 points (numpy's
MemoryError, a traceback), and one of 100 km wrote a 31 MB document for a 10 s run."""


def add_arguments(p):
    p.add_argument("scenario", type=Path, help="scenario file (TOML)")
    add_controller_arguments(p)
    p.add_argument("--out", type=Path, default=None, help="write RUN.json here")
    p.add_argument("--plot", type=Path, default=None, help="write a Fig. 7-style PNG here")
    p.add_argument("--animate", type=Path, default=None, help="write an animated GIF here")
    p.add_argument("--seed", type=int, default=None, help="override the scenario's sensing seed")


def run_one(scenario, spec: ControllerSpec | str, config, model=None, shield=None, passes=None, progress=None):
    """Simulate ``scenario`` with the controller ``spec`` names (or ``spec``, ``model``,
    ``shield``, ``passes`` as the controller's name and options) and return its RUN document
    (``progress``: a bar over the episode's samples, :func:`scenarios.simulator.simulate`)."""
    from scenarios.metrics import run_document
    from scenarios.simulator import simulate
    if isinstance(spec, str):
        spec = ControllerSpec(spec, model, shield, passes)
    controller = make(spec, config, scenario.robot)
    log = simulate(scenario, controller, spec.label, progress=progress)
    ref = scenario.reference  # the path drawn: a point every 0.1 m, at most REFERENCE_POINTS of them
    path = ref.polyline(max(0.1, ref.length_m / (REFERENCE_POINTS - 1)))[:, :2]
    extra = {"preset": config.name, "reference_path": path.tolist(),
             "robot_radius_m": scenario.robot.radius_m, "shield": spec.mode,  # docs/faults.md
             **recorded_changes(config, reads_planner_settings(spec)), "solve_lanes": config.solve_lanes}
    inner = getattr(controller, "policy", controller)  # the controller behind a Shield
    model_info = getattr(inner, "model_info", None)
    if model_info:
        extra["model"] = model_info
    solver_info = getattr(inner, "solver_info", None)
    if solver_info:
        extra["solver"] = solver_info  # the GPC's NLP solver (docs/solvers.md)
    if spec.name not in ("gpc", "nn"):
        extra["controller_settings"] = describe(controller)
    return run_document(log, extra)


def run(args) -> int:
    from scenarios import load_scenario
    from casadi_gpc.io import save_figure, write_json
    check_seed(args.seed)
    check_output_files(inputs=[args.scenario], models=[args.model, args.walls_model, args.crowd_model], out=args.out,
                       plot=args.plot, animate=args.animate)
    scenario = load_scenario(args.scenario)
    if args.seed is not None:
        scenario = scenario.with_seed(args.seed)
    from casadi_gpc.pool import WorkerPool
    config = for_pool(for_run(planner_config(args), [scenario]), WorkerPool(1))  # one process: lanes up to the cores
    spec = spec_from_args(args)
    refuse_unused_fallback(args, [spec])
    check(spec, config, scenario.robot)
    refuse_unread_changes([spec], config)
    doc = run_one(scenario, spec, config, progress=lambda **kw: progress(desc="simulating", **kw))
    if args.out:
        write_json(args.out, doc)
    if args.plot:
        from scenarios.plots import run_figure
        import matplotlib.pyplot as plt
        fig = run_figure(doc, scenario.robot.radius_m)
        save_figure(fig, args.plot, dpi=130)
        plt.close(fig)
    if args.animate:
        from scenarios.plots import animate_run
        animate_run(doc, args.animate, scenario.robot.radius_m,
                    progress=lambda **kw: progress(desc="animating", **kw))
    ct = doc["compute_time_s"]
    print(f"{doc['scenario']} [{spec.label}, preset {config.name}, T={doc['sample_time_s']} s]: "
          f"{doc['outcome']}  min clearance {doc['min_clearance_m']:.3f} m  tracking RMSE "
          f"{doc['tracking_rmse_m']:.3f} m  steps {doc['steps']}  decision median {ct['median'] * 1e3:.2f} ms "
          f"(p95 {ct['p95'] * 1e3:.2f})  fallbacks {doc['fallbacks']}", file=sys.stdout)
    return 0
