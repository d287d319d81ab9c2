"""How anisotropic are the planner's forecasts? For each forecast (mover, step) of a few GPC
episodes: the deviation along the mover's heading, across it, and the worst (the margin's)."""
import sys, numpy as np
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
cfg = preset("improved")
suite, movers, n = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rows = []
for i in range(n):
    sc = Suite(suite, 3, n, movers, "orca").scenario(i)
    pol = make(ControllerSpec("gpc"), cfg.for_walls(bool(sc.walls)), sc.robot)
    class Rec:
        def __init__(s, p): s.p = p
        def __getattr__(s, k): return getattr(s.p, k)
        def decide(s, o):
            d = s.p.decide(o)
            for f in (d.forecasts or ()):
                m = np.asarray(f.means_m); C = np.asarray(f.covs_m2)
                v = m[1] - m[0]
                if np.hypot(*v) < 0.05: continue
                u = v / np.hypot(*v); w = np.array([-u[1], u[0]])
                for k in (1, 5, 11):
                    a = np.sqrt(u @ C[k] @ u); c = np.sqrt(w @ C[k] @ w); worst = np.sqrt(np.linalg.eigvalsh(C[k]).max())
                    rows.append((k, a, c, worst))
            return d
    simulate(sc, Rec(pol), "gpc")
r = np.array(rows)
for k in (1, 5, 11):
    s = r[r[:, 0] == k]
    print(f"{suite} step {k+1} ({(k+1)*0.5:.1f} s): along median {np.median(s[:,1]):.3f} m, across {np.median(s[:,2]):.3f} m, worst {np.median(s[:,3]):.3f} m; across/along median {np.median(s[:,2]/s[:,1]):.2f} (p10 {np.percentile(s[:,2]/s[:,1],10):.2f}, p90 {np.percentile(s[:,2]/s[:,1],90):.2f}); n={len(s)}")
