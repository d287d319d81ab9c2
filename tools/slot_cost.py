"""What each mover slot of the planner's NLP costs, and what too few slots do (docs/crowds.md).

    python tools/slot_cost.py [--slots 1,3,6,10] [--episodes 3] [--movers 10] [--behaviour orca]

Runs the first episodes of ``circle-crossing`` (seed 1) closed loop with the ``improved``
planner alone (no check layer: the slots are its only safety) for each ``max_moving``, and
prints per slot count: the outcomes, the movers left out (``left_out``), the solves, the
median SQP iterations of the warm-started solves and the median time per iteration, also
relative to the preset's own slot count (times from one process; the ratios are what
counts on a loaded machine).
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from casadi_gpc.planner.candidates import START_ORDER  # noqa: E402
from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.planner.gpc import GPCController  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402
from scenarios import Suite  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--slots", default="1,3,6,10", help="comma-separated max_moving values")
    ap.add_argument("--episodes", type=int, default=3)
    ap.add_argument("--movers", type=int, default=10)
    ap.add_argument("--behaviour", default="orca", choices=("constant", "orca", "social_force"))
    a = ap.parse_args(argv)
    try:
        slots = [int(s) for s in a.slots.split(",")]
    except ValueError:
        ap.error(f"--slots: not a list of integers: {a.slots!r}")
    if not slots or min(slots) < 1 or a.episodes < 1:
        ap.error("--slots must be positive integers and --episodes at least 1")
    suite = Suite("circle-crossing", a.episodes, 1, a.movers, a.behaviour)
    episodes = [suite.scenario(i) for i in range(a.episodes)]
    base = preset("improved")
    rows = {}
    for m in slots:
        ctl = GPCController(dataclasses.replace(base, max_moving=m, crowd_moving=None), episodes[0].robot)
        solves, outcomes, left = [], [], 0
        original = ctl.solve_many

        def solve_many(p, starts, _orig=original, _out=solves):
            plans = _orig(p, starts)
            _out += [(r.guess, r.iterations, r.solve_time_s) for r in plans]
            return plans

        ctl.solve_many = solve_many
        for sc in episodes:
            outcomes.append(simulate(sc, ctl, "gpc").outcome)
            left += ctl.counters["left_out"]  # the counters start afresh with every episode
        fixed = set(START_ORDER) - {"warm"}
        warm = np.array([(it, t) for g, it, t in solves if g not in fixed], dtype=float)
        rows[m] = (outcomes, left, len(solves), float(np.median(warm[:, 0])),
                   float(np.median(warm[:, 1] / np.maximum(warm[:, 0], 1))))
    ref = rows.get(base.max_moving, rows[slots[0]])[4]
    print("| mover slots | outcomes | left out | solves | warm SQP iterations (median) | ms per iteration | relative |")
    print("|---|---|---|---|---|---|---|")
    for m, (outcomes, left, n, it, per) in rows.items():
        print(f"| {m} | {', '.join(outcomes)} | {left} | {n} | {it:.0f} | {per * 1e3:.3f} | {per / ref:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
