import sys, json, numpy as np
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
cfg = preset("improved")
seed = int(sys.argv[1]); idxs = [int(x) for x in sys.argv[2].split(",")]; out = sys.argv[3]
res = {}
suite = Suite("ucy", max(idxs) + 1, seed, 5, "orca")
for i in idxs:
    sc = suite.scenario(i)
    log = simulate(sc, make(ControllerSpec("nn"), cfg, sc.robot), "nn")
    res[sc.name] = {"outcome": log.outcome, "cmds": [(d.v_right_mps, d.v_left_mps) for d in log.decisions],
                    "t": list(log.compute_time_s), "chk": [d.info.get("safety_time_s", 0) for d in log.decisions]}
json.dump(res, open(out, "w"))
