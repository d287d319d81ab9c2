"""The bench scene's first N episodes (circle-crossing, 10 ORCA walkers, seed 1) closed loop
with the deployed network (``--controller nn``): the decisions' median, p99, max and share over
1 ms, the outcomes and interventions, as one JSON line. Run from a checkout (PYTHONPATH) to
compare two versions of the code in the same hour.

    PYTHONPATH=. python docs/data/deploy/clearance_norm/benchnn.py 3
"""
import sys, numpy as np, json
from scenarios import Suite
from gpcnav.controllers import ControllerSpec, make
from casadi_gpc.config import preset
from gpcnav.benchmarks.decisions import policy_decision_run
cfg = preset("improved")
out = []
for ep in range(int(sys.argv[1])):
    sc = Suite("circle-crossing", 200, 1, 10, "orca").scenario(ep)
    r = policy_decision_run(sc, "nn", make(ControllerSpec("nn"), cfg, sc.robot))
    out.append((r["outcome"], r["interventions"], r["time_samples_s"]))
t = np.concatenate([np.array(x[2]) for x in out])*1e3
print(json.dumps({"median": np.median(t), "p99": np.percentile(t, 99), "max": t.max(), "n": len(t), "over1ms": float((t>1).mean()),
  "outcomes": [x[0] for x in out], "interv": [x[1] for x in out]}))
