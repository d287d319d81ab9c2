import sys, numpy as np, time
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from gpcnav.benchmarks.decisions import policy_decision_run, decision_run
n = int(sys.argv[1]); which = sys.argv[2] if len(sys.argv) > 2 else "nn,gpc"
cfg = preset("improved")
suite = Suite("circle-crossing", n, 1, 10, "orca")
out = {}
for name in which.split(","):
    ts = []; t0 = time.time()
    for i in range(n):
        sc = suite.scenario(i)
        d = policy_decision_run(sc, "nn", make(ControllerSpec("nn"), cfg, sc.robot)) if name == "nn" else decision_run(sc, cfg)
        ts += d["time_samples_s"]
    t = np.array(ts) * 1e3
    out[name] = t
    print(f"{name}: {len(t)} decisions in {time.time()-t0:.0f} s: median {np.median(t):.3f} ms p99 {np.percentile(t,99):.2f} max {t.max():.2f}; share > 1 ms {np.mean(t>1):.3f}")
if len(out) == 2:
    for q in (50, 99):
        print(f"ratio at p{q}: {np.percentile(out['gpc'], q)/np.percentile(out['nn'], q):.1f}")
