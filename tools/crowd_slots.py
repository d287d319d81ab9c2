"""The GPC behind its check with and without the crowd NLP (``PlannerConfig.crowd_moving``)
on the same episodes, alternated episode by episode in one process so both meet the same
load: outcomes, collisions with the robot approaching, and decision times (median, p99,
max), with the ratio of the medians.

A study instrument (docs/pedestrians.md, "Slots for a crowd"): ``without`` is the planner
as it was before the crowd NLP, bit for bit (one NLP of ``max_moving`` slots).

Usage: ``python tools/crowd_slots.py --suite square-crossing --movers 30 --count 20 --seed 1
[--behaviour orca] [--out SLOTS.json]``. Prints a Markdown table.
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.io import write_json  # noqa: E402
from gpcnav.commands.common import for_run  # noqa: E402
from gpcnav.controllers import make_controller  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402
from scenarios.suites import SUITES, Suite  # noqa: E402


def run(suite: Suite, preset_name: str = "improved") -> dict:
    scenarios = suite.scenarios()
    with_crowd = for_run(preset(preset_name), scenarios)
    if with_crowd.crowd_moving is None:
        raise SystemExit(f"{suite.name}: no scene has more movers than the {with_crowd.max_moving} slots; "
                         "the crowd NLP is never solved there")
    configs = {"with": with_crowd, "without": replace(with_crowd, crowd_moving=None)}
    controllers = {k: make_controller("gpc", c, scenarios[0].robot) for k, c in configs.items()}
    rows = {k: {"times_s": [], "episodes": []} for k in configs}
    for i, sc in enumerate(scenarios):
        for k in (("with", "without") if i % 2 == 0 else ("without", "with")):
            log = simulate(sc, controllers[k], k)
            c = log.collision or {}
            rows[k]["times_s"] += [float(t) for t in log.compute_time_s]
            rows[k]["episodes"].append({"scenario": sc.name, "outcome": log.outcome, "approaching":
                                        bool(c) and c.get("robot_speed_towards_mps", 0.0) > 0.05
                                        and c.get("obstacle_age_s", 0.0) >= 1.0})
    for k, r in rows.items():
        t = np.asarray(r["times_s"])
        r["time_s"] = {"median": float(np.median(t)), "p99": float(np.percentile(t, 99)), "max": float(t.max()),
                       "decisions": int(t.size)}
        for o in ("reached_goal", "collided", "timed_out"):
            r[o] = sum(e["outcome"] == o for e in r["episodes"])
        r["collided_robot_approaching"] = sum(e["approaching"] for e in r["episodes"])
    ratio = rows["with"]["time_s"]["median"] / rows["without"]["time_s"]["median"]
    return {"suite": suite.describe(), "preset": preset_name, "crowd_moving": with_crowd.crowd_moving,
            "max_moving": with_crowd.max_moving, "median_ratio_with_over_without": ratio, "rows": rows}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite", choices=SUITES, default="square-crossing")
    ap.add_argument("--movers", type=int, default=30)
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--behaviour", default=None)
    ap.add_argument("--preset", default="improved")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    try:
        suite = Suite(args.suite, args.count, args.seed, args.movers, args.behaviour)
    except ValueError as exc:
        ap.error(str(exc))
    doc = run(suite, args.preset)
    print(f"{args.suite} ({args.movers} movers), {args.count} episodes, seed {args.seed}, {args.preset}\n")
    print("| GPC | reached | collided (robot approaching) | timed out | decision median / p99 / max ms |")
    print("|---|---|---|---|---|")
    for k, r in doc["rows"].items():
        t = r["time_s"]
        print(f"| {k} the crowd NLP | {r['reached_goal']} | {r['collided']} ({r['collided_robot_approaching']}) | "
              f"{r['timed_out']} | {1e3 * t['median']:.2f} / {1e3 * t['p99']:.1f} / {1e3 * t['max']:.1f} |")
    print(f"\nmedian with / without: {doc['median_ratio_with_over_without']:.2f}")
    if args.out is not None:
        write_json(args.out, doc)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
