"""Offline: how far simple predictors of the walkers are off, at 0.5 to 6 s (docs/pedestrians.md,
"Among 30 walkers"). Usage: python predictors_offline.py SUITE SEED MOVERS EPISODES
(e.g. square-crossing 3 30 10; corridor 3 5 40). The walkers must not see the robot."""
import sys, numpy as np
from dataclasses import replace
sys.path.insert(0, str(__import__('pathlib').Path(__file__).resolve().parents[4]))  # the repository
sys.path.insert(0, str(__import__('pathlib').Path(__file__).resolve().parents[4] / 'tools'))
from oracle_forecasts import true_positions  # noqa: E402
from scenarios import Suite
from casadi_gpc.estimation.ekf import ObstacleEKF, EKFSettings
T, H = 0.5, 12
suite, seed, movers, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
def truth_of(sc):  # the walkers' true positions at every sample of the episode, NaN where absent
    return true_positions(sc, T, 0, hold_absent=False)[:int(sc.duration_s / T) + 1]
S0 = EKFSettings()
ests = {'ekf': S0}
for k in (2, 4, 8):
    ests[f'ekf_x{k}'] = replace(S0, speed_noise_mps2=S0.speed_noise_mps2*k, heading_noise_rad=S0.heading_noise_rad*k)
steps = [1, 2, 4, 8, 12]
err = {name: [] for name in list(ests) + ['cv1', 'cv2', 'cv3', 'cv1true']}
rng = np.random.default_rng(5)
for idx in range(count):
    sc = Suite(suite, idx+1, seed, movers).scenario(idx)
    tr = truth_of(sc)
    K, n = tr.shape[0], tr.shape[1]
    Z = tr + rng.normal(0, 0.02, tr.shape)
    for j in range(n):
        filt = {name: ObstacleEKF(T, s) for name, s in ests.items()}
        for k in range(K - H):
            if not np.all(np.isfinite(tr[k:k+H+1, j])): break
            for name, f in filt.items():
                f.step((float(Z[k, j, 0]), float(Z[k, j, 1])))
            if k < 4: continue
            fut = tr[k+1:k+H+1, j]
            for name, f in filt.items():
                m, _ = f.predict(H, straight=True)
                err[name].append(np.hypot(*(m - fut).T))
            for c in (1, 2, 3):
                v = (Z[k, j] - Z[k-c, j]) / c
                m = Z[k, j] + np.arange(1, H+1)[:, None] * v
                err[f'cv{c}'].append(np.hypot(*(m - fut).T))
            v = tr[k, j] - tr[k-1, j]; m = tr[k, j] + np.arange(1, H+1)[:, None] * v
            err['cv1true'].append(np.hypot(*(m - fut).T))
print(f"{suite} seed {seed} movers {movers}, {count} episodes: mean position error (m) at steps {steps}; ADE over 1-4 / 1-12")
for name, e in err.items():
    e = np.array(e)
    print(f"{name:8s} n={len(e):6d} " + ' '.join(f"{e[:, s-1].mean():.3f}" for s in steps) + f"   {e[:, :4].mean():.3f} / {e.mean():.3f}")
print("p95 of the error at steps", steps)
for name, e in err.items():
    e = np.array(e)
    print(f"{name:8s} " + ' '.join(f"{np.percentile(e[:, s-1],95):.3f}" for s in steps))
