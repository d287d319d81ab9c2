"""The bench scene's first 10 crossings closed loop (--controller nn), the set networks by onnxruntime and
compiled, alternated; the decision times and the episodes that differ. PYTHONPATH=REPO python ab.py [SEED]"""
import sys, numpy as np
import nn_export.runtime.side_networks as sn
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
init = sn.CrowdNetwork.__init__
cfg = preset("improved")
suite = Suite("circle-crossing", 10, int(sys.argv[1]) if len(sys.argv) > 1 else 1, 10, "orca")
def run(compiled, n=10):
    def patched(self, *a, **k):
        init(self, *a[:4], compiled)
    sn.CrowdNetwork.__init__ = patched
    ts, res = [], []
    for i in range(n):
        sc = suite.scenario(i); pol = make(ControllerSpec("nn"), cfg, sc.robot)
        log = simulate(sc, pol, "nn"); ts += list(log.compute_time_s)
        res.append((log.outcome, len(log.decisions), round(float(log.min_clearance_m), 9)))
    return np.array(ts) * 1e6, res
for rnd in range(3):
    out = {}
    for name, c in (("onnxruntime", False), ("compiled", True)):
        t, res = run(c); out[name] = res
        print(f"round {rnd} {name}: {len(t)} decisions median {np.median(t):.0f} us p99 {np.percentile(t, 99):.0f} max {t.max():.0f}", flush=True)
    diff = [(a, b) for a, b in zip(out["onnxruntime"], out["compiled"]) if a[:2] != b[:2]]
    print("  episodes differing in outcome or steps:", diff, flush=True)
