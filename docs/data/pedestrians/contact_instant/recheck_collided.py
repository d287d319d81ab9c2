"""The collided episodes of suite runs (EVAL.json documents of `gpcnav evaluate --suite ...`) again,
with the simulator that measures a collision where it happens (2026-11-30): the same outcome and
time, and the robot's speed towards the obstacle as measured now beside the old figure.

    python recheck_collided.py EVAL.json ... > OUT.json
"""
import json
import sys

from casadi_gpc.config import preset
from gpcnav.commands.common import for_run
from gpcnav.controllers import ControllerSpec, make
from scenarios import Suite
from scenarios.simulator import simulate


def main(paths):
    out = {}
    for path in paths:
        d = json.load(open(path))
        spec, name = d["suite_spec"], d["controller"] if isinstance(d["controller"], str) else d["controller"]["name"]
        suite = Suite(spec["suite"], spec["count"], spec["seed"], spec.get("movers", 5), spec.get("behaviour"))
        cfg = for_run(preset(d.get("preset", "improved")), [suite.scenario(0)])
        rows = []
        for e in d["episodes_detail"]:
            if e["outcome"] != "collided":
                continue
            sc = suite.scenario(int(e["scenario"].rsplit("-", 1)[1]))
            assert sc.name == e["scenario"], (sc.name, e["scenario"])
            log = simulate(sc, make(ControllerSpec(name), cfg, sc.robot), name)
            c, was = log.collision or {}, e["collision"]
            rows.append({"scenario": sc.name, "outcome": log.outcome, "time_s": c.get("time_s"), "was_time_s": was["time_s"],
                         "obstacle": c.get("obstacle"), "obstacle_age_s": c.get("obstacle_age_s"),
                         "robot_speed_towards_mps": c.get("robot_speed_towards_mps"),
                         "was_robot_speed_towards_mps": was["robot_speed_towards_mps"]})
            print(path, sc.name, log.outcome, rows[-1]["robot_speed_towards_mps"], was["robot_speed_towards_mps"],
                  file=sys.stderr, flush=True)
        out[path] = rows
    print(json.dumps(out, indent=1, default=float))


if __name__ == "__main__":
    main(sys.argv[1:])
