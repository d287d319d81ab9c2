"""Offline: forecast error, coverage (within 2 worst-direction sigma) and sigma of the shipped
filter, the adaptive one and people's noise, at 0.5 / 2 / 6 s. Usage: offline.py SUITE SEED MOVERS COUNT [BEHAVIOUR]"""
import sys, numpy as np
from dataclasses import replace
from pathlib import Path; _r = Path(__file__).resolve().parents[4]; sys.path[:0] = [str(_r), str(_r / 'tools'), str(Path(__file__).resolve().parent)]
from oracle_forecasts import true_positions
from scenarios import Suite
from casadi_gpc.estimation import ekf as E
import adaptive
T, H = 0.5, 12
suite, seed, movers, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
beh = sys.argv[5] if len(sys.argv) > 5 else None
S0 = E.EKFSettings()
orig_step = E.ObstacleEKF.step
adaptive.install(); adapt_step = E.ObstacleEKF.step
class Plain(E.ObstacleEKF): step = orig_step
class Adapt(E.ObstacleEKF): step = adapt_step
kinds = {'shipped': (Plain, S0), 'adaptive': (Adapt, S0), 'people': (Plain, replace(S0, **adaptive.CAP))}
steps = [1, 4, 12]
R = {k: {'err': [], 'cov': [], 'std': []} for k in kinds}
rng = np.random.default_rng(5)
for idx in range(count):
    sc = (Suite(suite, count, seed, movers, beh) if beh else Suite(suite, count, seed, movers)).scenario(idx)
    tr = true_positions(sc, T, 0, hold_absent=False)[:int(sc.duration_s / T) + 1]
    K, n = tr.shape[0], tr.shape[1]
    Z = tr + rng.normal(0, 0.02, tr.shape)
    for j in range(n):
        fs = {k: cls(T, st) for k, (cls, st) in kinds.items()}
        seen = 0
        for k in range(K - H):
            if not np.all(np.isfinite(tr[k:k + H + 1, j])):
                if seen: break
                continue
            seen += 1
            for f in fs.values(): f.step((float(Z[k, j, 0]), float(Z[k, j, 1])))
            if seen < 5: continue
            fut = tr[k + 1:k + H + 1, j]
            for name, f in fs.items():
                m, c = f.predict(H, straight=True)
                e = np.hypot(*(m - fut).T); s = E.worst_std_m(c)
                R[name]['err'].append(e); R[name]['std'].append(s); R[name]['cov'].append(e <= 2 * s)
print(f"{suite} seed {seed} movers {movers} {beh or ''}, {count} episodes; at {[s * T for s in steps]} s: mean error / within 2 sigma / median sigma")
for name, r in R.items():
    e, c, s = (np.array(r[x]) for x in ('err', 'cov', 'std'))
    print(f"{name:9s} n={len(e):6d} " + '   '.join(f"{e[:, i-1].mean():.3f} / {c[:, i-1].mean():.2f} / {np.median(s[:, i-1]):.3f}" for i in steps))
