"""The bench scene's first 10 episodes closed loop, the deployable decision (--controller nn), timed with the
code of REPO (argv[1]; run with PYTHONPATH=REPO): median and p99 over the 533 decisions."""
import sys, numpy as np, time
sys.path.insert(0, sys.argv[1])
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from gpcnav.benchmarks.decisions import policy_decision_run
cfg = preset("improved"); suite = Suite("circle-crossing", 10, 1, 10, "orca")
ts = []
for i in range(10):
    sc = suite.scenario(i)
    d = policy_decision_run(sc, "nn", make(ControllerSpec("nn"), cfg, sc.robot)); ts += d["time_samples_s"]
t = np.array(ts) * 1e3
print(sys.argv[1], len(t), f"median {np.median(t):.3f} p99 {np.percentile(t,99):.2f}")
