"""One scenario, several controllers, side by side: each run drawn as `gpcnav simulate --plot`
draws it (scenarios.plots.plot_run), so a reader sees where the planners differ.

Usage: ``python tools/case_figure.py SCENARIO.toml --controllers gpc,nn,mppi --out FIG.png``, or
``--suite corridor --index 0 [--seed 1] [--movers 5] [--behaviour orca]`` for a suite's scenario instead of a file
(the controllers as the registry names them, each as ``gpcnav simulate`` makes it).
``--window X0 X1 Y0 Y1`` (m) shows only that part of the plane (a scene whose walkers head for
goals far away, as navground's unwrapped corridor, is otherwise drawn at their scale).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import matplotlib.pyplot as plt  # noqa: E402

from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.io import save_figure  # noqa: E402
from gpcnav.commands.common import for_run  # noqa: E402
from gpcnav.commands.simulate import run_one  # noqa: E402
from scenarios import load_scenario  # noqa: E402
from scenarios.plots import plot_run  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenario", type=Path, nargs="?")
    ap.add_argument("--suite", default=None)
    ap.add_argument("--index", type=int, default=0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--movers", type=int, default=5)
    ap.add_argument("--behaviour", default=None, help="the suite's movers (as evaluate's --behaviour)")
    ap.add_argument("--controllers", default="gpc,nn,mppi")
    ap.add_argument("--preset", default="improved")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--window", type=float, nargs=4, metavar=("X0", "X1", "Y0", "Y1"), default=None,
                    help="show only x0..x1, y0..y1 (m)")
    args = ap.parse_args(argv)
    if args.window is not None and not (args.window[0] < args.window[1] and args.window[2] < args.window[3]):
        ap.error("--window X0 X1 Y0 Y1 needs X0 < X1 and Y0 < Y1")
    if args.suite:
        from scenarios import Suite
        sc = Suite(args.suite, args.index + 1, args.seed, args.movers, args.behaviour).scenario(args.index)
    else:
        sc = load_scenario(args.scenario)
    names = args.controllers.split(",")
    cols = min(2, len(names))
    rows = -(-len(names) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(7.0 * cols, 5.2 * rows), squeeze=False)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    for ax, name in zip(axes.flat, names):
        doc = run_one(sc, name, for_run(preset(args.preset), [sc]))
        clr = doc["min_clearance_m"]
        plot_run(ax, doc, sc.robot.radius_m, mark_every_s=4.0,
                 title=f"{name}: {doc['outcome']}, smallest clearance {clr:.2f} m")
        if args.window is not None:
            ax.set_adjustable("box")  # keep the equal aspect, fit the box to the window
            ax.set_xlim(*args.window[:2])
            ax.set_ylim(*args.window[2:])
        print(name, doc["outcome"], round(clr, 3), doc.get("collision"))
    fig.suptitle(f"{sc.name}: {sc.description}", fontsize=9)
    fig.tight_layout()
    save_figure(fig, args.out, dpi=110)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
