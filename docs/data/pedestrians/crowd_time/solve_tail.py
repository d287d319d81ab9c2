"""Every solve of the hybrid solver (sqpmethod-daqp+fatrop) in closed loop on the first N case files: warm starts the
SQP solved, warm starts it left to fatrop (retries) and cold starts, their times and iterations, the slowest twelve.

    python solve_tail.py "FOLDER/*.toml" N

The capped run of docs/pedestrians.md was this script with the SQP's max_iter set to 40 in
casadi_gpc/solvers/sqp.py (_SQP), a patch not kept."""
import sys, glob, numpy as np, threading
from scenarios import load_scenario
from scenarios.simulator import simulate
from casadi_gpc.config import preset
from gpcnav.controllers import ControllerSpec, make
from gpcnav.commands.common import for_run
from casadi_gpc.solvers import hybrid
calls = []
lock = threading.Lock()
orig_solve = hybrid.HybridBackend._solve
def traced(self, p, u0, lam_x, lam_g):
    r = orig_solve(self, p, u0, lam_x, lam_g)
    kind = "cold" if lam_x is None else ("warm" if "after" not in r.status else "warm+retry")
    with lock:
        calls.append((kind, r.solve_time_s, r.iterations, r.success, r.status[:60]))
    return r
hybrid.HybridBackend._solve = traced
files = sorted(glob.glob(sys.argv[1]))[: int(sys.argv[2])]
for f in files:
    sc = load_scenario(f)
    cfg = for_run(preset("improved"), [sc])
    pol = make(ControllerSpec("gpc"), cfg, sc.robot)
    simulate(sc, pol, "gpc")
t = np.array([c[1] for c in calls]) * 1e3
print("solves", len(calls), "median %.2f p99 %.1f max %.1f" % (np.median(t), np.percentile(t, 99), t.max()))
for kind in ("warm", "warm+retry", "cold"):
    sel = [c for c in calls if c[0] == kind]
    if sel:
        tt = np.array([c[1] for c in sel]) * 1e3; it = np.array([c[2] for c in sel])
        print(kind, len(sel), "time med %.2f p99 %.1f max %.1f | iters med %d p99 %d max %d | fail %d" % (np.median(tt), np.percentile(tt, 99), tt.max(), np.median(it), np.percentile(it, 99), it.max(), sum(not c[3] for c in sel)))
for c in sorted(calls, key=lambda c: -c[1])[:12]:
    print(c[0], round(c[1]*1e3, 1), c[2], c[3], c[4])
w = np.array([c[2] for c in calls if c[0] == "warm"])
for cap in (20, 30, 40, 50, 60, 80):
    print("warm successes above", cap, "iterations:", int((w > cap).sum()), "of", len(w))
wt = np.array([c[1] for c in calls if c[0] == "warm"]) * 1e3
print("ms per SQP iteration (median over warm solves):", np.median(wt / np.maximum(w, 1)))
