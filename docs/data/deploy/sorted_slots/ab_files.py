import sys, json
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios import load_scenario
from scenarios.simulator import simulate
cfg = preset("improved"); out = sys.argv[1]; res = {}
for f in sys.argv[2:]:
    sc = load_scenario(f)
    log = simulate(sc, make(ControllerSpec("nn"), cfg, sc.robot), "nn")
    res[sc.name] = {"outcome": log.outcome, "cmds": [(d.v_right_mps, d.v_left_mps) for d in log.decisions],
                    "t": list(log.compute_time_s), "chk": [d.info.get("safety_time_s", 0) for d in log.decisions]}
json.dump(res, open(out, "w"))
