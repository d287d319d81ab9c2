import numpy as np
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from gpcnav.benchmarks.decisions import policy_decision_run
sc = Suite("circle-crossing", 1, 1, 10, "orca").scenario(0)
cfg = preset("improved")
for r in range(3):
    pol = make(ControllerSpec("nn"), cfg, sc.robot)
    for name, p in (("shielded", pol), ("bare", pol.policy)):
        d = policy_decision_run(sc, "nn", p)
        t = np.array(d["time_samples_s"]) * 1e6
        print(f"{name:9s} n={len(t)} median {np.median(t):.0f} p99 {np.percentile(t,99):.0f}")
