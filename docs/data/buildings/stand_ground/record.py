"""Record, per episode, the robot's pose and every measured person (id, position) at each
decision of a controller (default ``stand``: a robot that holds its ground), on navground
Corridor files as exported (people who see the robot) or with every walker made blind
(``sees_robot = false``): the data of the stand-your-ground study (docs/buildings.md).

    python record.py OUT.json 'FILES_GLOB' COUNT [see|blind] [controller]
"""
import glob
import json
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from casadi_gpc.config import preset
from gpcnav.controllers import ControllerSpec, make
from scenarios.loader import load_scenario
from scenarios.simulator import simulate


def one(job):
    path, mode, name = job
    text = Path(path).read_text()
    if mode == "blind":
        text = text.replace("sees_robot = true", "sees_robot = false")
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / Path(path).name
        p.write_text(text)
        sc = load_scenario(p)
    pol = make(ControllerSpec(name), preset("improved"), sc.robot)
    rows = []

    class Rec:
        sample_time_s = pol.sample_time_s
        counters = {}

        def reset(self):
            pol.reset()

        def decide(self, o):
            rows.append([o.t_s, o.robot.x_m, o.robot.y_m, o.robot.heading_rad,
                         [[m.obstacle_id, *(m.position_m or (None, None))] for m in o.moving]])
            return pol.decide(o)

    log = simulate(sc, Rec(), name)
    return {"name": Path(path).name, "mode": mode, "outcome": log.outcome, "rows": rows}


if __name__ == "__main__":
    out, pat, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
    mode = sys.argv[4] if len(sys.argv) > 4 else "see"
    name = sys.argv[5] if len(sys.argv) > 5 else "stand"
    jobs = [(f, mode, name) for f in sorted(glob.glob(pat))[:n]]
    with ProcessPoolExecutor(2) as ex:
        res = list(ex.map(one, jobs))
    json.dump(res, open(out, "w"))
    print(out, len(res), {o: sum(r["outcome"] == o for r in res) for o in {r["outcome"] for r in res}})
