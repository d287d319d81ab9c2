"""The collided episodes of the rule's runs (runs/NAME-*.json) again, with the simulator that
measures a collision where it happens (2026-11-30: the robot's speed towards what it hit was taken
a whole interval past the contact before): the same outcome and time, and the speed towards the
obstacle as measured now. Run from the checkout with the walls network NAME was run with:

    PYTHONPATH=CHECKOUT python recheck.py NAME > runs/NAME-recheck.json
"""
import json
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "pillars"))

from pillars import with_pillar  # noqa: E402
from casadi_gpc.config import preset  # noqa: E402
from gpcnav.commands.common import for_run  # noqa: E402
from gpcnav.controllers import ControllerSpec, make  # noqa: E402
from scenarios import Suite, load_scenario  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402

NG = Path(sys.argv[2]) if len(sys.argv) > 2 else HERE.parents[3] / "out" / "walls2" / "ng-6701"


def collided(path: Path):
    d = json.loads(path.read_text())
    eps = d["episodes"] if isinstance(d.get("episodes"), list) else d["episodes_detail"]
    return [e for e in eps if e["outcome"] == "collided"]


def scenario_of(key: str, e: dict):
    if key.startswith("pillar-"):
        suite = key.split("-")[1]
        i = e["episode"]
        return with_pillar(Suite(suite, i + 1, 404, 5, "orca").scenario(i), np.random.default_rng([404, i]))
    if key == "ng6701":
        return load_scenario(NG / f"{e['scenario']}.toml")
    suite, i = key.split("-")[0], int(e["scenario"].rsplit("-", 1)[1])
    return Suite(suite, i + 1, 42, 5, "orca").scenario(i)


def main(name: str) -> None:
    out = {}
    for path in sorted((HERE / "runs").glob(f"{name}-*.json")):
        key = path.stem[len(name) + 1:]
        if key == "recheck":
            continue
        for e in collided(path):
            sc = scenario_of(key, e)
            log = simulate(sc, make(ControllerSpec("nn"), for_run(preset("improved"), [sc]), sc.robot), "nn")
            c = log.collision or {}
            was = (e.get("collision") or {}).get("robot_speed_towards_mps")
            out.setdefault(key, []).append({"scenario": sc.name, "outcome": log.outcome, "time_s": c.get("time_s"),
                                            "was_time_s": (e.get("collision") or {}).get("time_s"),
                                            "robot_speed_towards_mps": c.get("robot_speed_towards_mps"),
                                            "was_robot_speed_towards_mps": was, "obstacle": c.get("obstacle")})
            print(key, sc.name, log.outcome, c.get("robot_speed_towards_mps"), was, file=sys.stderr, flush=True)
    print(json.dumps(out, indent=1, default=float))


if __name__ == "__main__":
    main(sys.argv[1])
