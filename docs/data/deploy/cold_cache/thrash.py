import sys, time, numpy as np
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
sc = Suite("circle-crossing", 1, 1, 10, "orca").scenario(0)
cfg = preset("improved")
pol = make(ControllerSpec("nn"), cfg, sc.robot)
obs = []
class Rec:
    def __init__(s, p): s.p = p
    def __getattr__(s, k): return getattr(s.p, k)
    def decide(s, o):
        obs.append(o); return s.p.decide(o)
simulate(sc, Rec(pol), "nn")
big = np.ones(4_000_000)
junk = [dict(a=i, b=str(i)) for i in range(100000)]
def thrash_data(): big.sum()
def thrash_py():
    s = 0
    for d in junk[:20000]: s += d["a"]
def run(th):
    pol.reset(); ts = []
    for o in obs:
        th(); t = time.perf_counter(); pol.decide(o); ts.append(time.perf_counter() - t)
    return np.array(ts) * 1e6
for name, th in [("none", lambda: None), ("data 32MB", thrash_data), ("python 20k dicts", thrash_py)]*2:
    a = np.array([run(th) for _ in range(5)])
    m = np.median(a, axis=0)
    print(f"{name:18s} median {np.median(m):.0f} p99 {np.percentile(m,99):.0f}")
