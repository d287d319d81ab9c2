"""Record, per episode, the robot's pose and every measured person (id, position) at each
decision of the shipped GPC: the data of the give-way study."""
import sys, json, glob
from concurrent.futures import ProcessPoolExecutor
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.loader import load_scenario
from scenarios.simulator import simulate

def one(job):
    kind, arg = job
    sc = load_scenario(arg) if kind == "file" else None
    if kind == "suite":
        name, count, seed, movers, behaviour, i = arg
        sc = Suite(name, count, seed, movers, behaviour).scenario(i)
    cfg = preset("improved")
    pol = make(ControllerSpec("gpc"), cfg, sc.robot)
    rows = []
    class Rec:
        sample_time_s = pol.sample_time_s
        counters = {}
        def reset(s): pol.reset()
        def decide(s, o):
            rows.append([o.t_s, o.robot.x_m, o.robot.y_m, o.robot.heading_rad,
                         [[m.obstacle_id, *(m.position_m or (None, None))] for m in o.moving]])
            return pol.decide(o)
    log = simulate(sc, Rec(), "gpc")
    return {"name": str(arg), "outcome": log.outcome if hasattr(log, "outcome") else None, "rows": rows}

if __name__ == "__main__":
    out, jobs = sys.argv[1], []
    spec = sys.argv[2]
    if spec.startswith("files:"):
        pat, n = spec[6:].rsplit(":", 1)
        jobs = [("file", f) for f in sorted(glob.glob(pat))[:int(n)]]
    else:  # suite:name:seed:movers:behaviour:count
        _, name, seed, movers, beh, n = spec.split(":")
        jobs = [("suite", (name, int(n), int(seed), int(movers), beh, i)) for i in range(int(n))]
    with ProcessPoolExecutor(2) as ex:
        res = list(ex.map(one, jobs))
    json.dump(res, open(out, "w"))
    print(out, len(res))
