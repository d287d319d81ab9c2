"""Cold starts recorded among 30 walkers, solved again by fatrop with other options: time,
iterations, success, and the cost against the shipped options' solve of the same problem."""
import sys, time, collections, numpy as np
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
import casadi_gpc.solvers.fatrop as F

recorded = []  # (problem, p, u0)
orig = F.FatropBackend._solve
def _solve(self, p, u0, lam_x, lam_g):
    if lam_x is None and len(recorded) < 400:
        recorded.append((self.problem, np.array(p, float).copy(), np.array(u0, float).copy()))
    return orig(self, p, u0, lam_x, lam_g)
F.FatropBackend._solve = _solve
movers = int(sys.argv[1]) if not sys.argv[1].startswith("files:") else 0
cfg = preset("improved")
import glob
from scenarios.loader import load_scenario
from gpcnav.commands.common import for_run
if sys.argv[1].startswith("files:"):
    scs = [load_scenario(f) for f in sorted(glob.glob(sys.argv[1][6:]))[:int(sys.argv[2])]]
else:
    scs = [Suite("square-crossing", ep + 1, 1, movers, "orca").scenario(ep) for ep in range(int(sys.argv[2]))]
for sc in scs:
    c = for_run(cfg, [sc])
    simulate(sc, make(ControllerSpec("gpc"), c, sc.robot), "gpc")
F.FatropBackend._solve = orig
by_problem = collections.defaultdict(list)
for prob, p, u0 in recorded:
    by_problem[id(prob)].append((prob, p, u0))
print(len(recorded), "cold starts,", len(by_problem), "problems")
variants = {"shipped": {}}
for arg in sys.argv[3:]:
    k, v = arg.split("=")
    v = {"True": True, "False": False}.get(v, v)
    try:
        v = float(v) if "." in v or "e" in v else int(v)
    except (TypeError, ValueError):
        pass
    variants[arg] = {k: v}
base_opts = dict(F._FATROP)
results = {}
for name, extra in variants.items():
    F._FATROP.clear(); F._FATROP.update(base_opts, **extra)
    backs = {}
    out = []
    for prob, p, u0 in recorded:
        b = backs.get(id(prob))
        if b is None:
            b = backs[id(prob)] = F.FatropBackend("fatrop", prob, True)
        out.append(b._solve(p, u0, None, None))
    results[name] = out
F._FATROP.clear(); F._FATROP.update(base_opts)
base = results["shipped"]
for rep in range(2):
  for name, extra in variants.items():
    backs = {}
    F._FATROP.clear(); F._FATROP.update(base_opts, **extra)
    ts = []
    for prob, p, u0 in recorded:
        b = backs.get(id(prob))
        if b is None:
            b = backs[id(prob)] = F.FatropBackend("fatrop", prob, True)
        ts.append(b._solve(p, u0, None, None).solve_time_s)
    out = results[name]
    ok = np.array([r.success for r in out]); it = np.array([r.iterations for r in out])
    dc = np.array([r.cost - s.cost for r, s in zip(out, base) if r.success and s.success])
    same = np.mean([np.allclose(r.u, s.u, atol=1e-6) for r, s in zip(out, base) if r.success and s.success])
    ts = np.array(ts) * 1e3
    print(f"{name:32s} time median {np.median(ts):.3f} ms mean {ts.mean():.3f} p90 {np.percentile(ts, 90):.3f} | "
          f"iters median {np.median(it):.0f} mean {it.mean():.1f} | success {ok.mean():.3f} | "
          f"cost - shipped: median {np.median(dc):.2e} max {dc.max():.2e} min {dc.min():.2e} | same u {same:.3f}")
