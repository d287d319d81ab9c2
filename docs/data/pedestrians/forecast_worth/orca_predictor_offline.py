"""Offline: an ORCA forecast of the walkers among themselves, from the filter's estimates and
from the true state, against the filter's straight one (square-crossing, 30 walkers, seed 3,
the first 3 episodes; docs/pedestrians.md, "Among 30 walkers")."""
import sys, numpy as np, types
sys.path.insert(0, str(__import__('pathlib').Path(__file__).resolve().parents[4]))  # the repository
sys.path.insert(0, str(__import__('pathlib').Path(__file__).resolve().parents[4] / 'tools'))
from oracle_forecasts import true_positions  # noqa: E402
from scenarios import Suite
from scenarios.movers import MoverWorld
from casadi_gpc.estimation.ekf import ObstacleEKF, EKFSettings
T, H = 0.5, 12
def truth_of(sc):  # the walkers' true positions at every sample of the episode, NaN where absent
    return true_positions(sc, T, 0, hold_absent=False)[:int(sc.duration_s / T) + 1]
rng = np.random.default_rng(5)
E = {'straight': [], 'orca': [], 'orca_truestate': []}
for idx in range(3):
    sc = Suite('square-crossing', idx+1, 3, 30).scenario(idx)
    tr = truth_of(sc); K, n = tr.shape[:2]
    Z = tr + rng.normal(0, 0.02, tr.shape)
    filt = [ObstacleEKF(T, EKFSettings()) for _ in range(n)]
    for k in range(K - H):
        means = []
        for j in range(n):
            filt[j].step((float(Z[k, j, 0]), float(Z[k, j, 1])))
            m, _ = filt[j].predict(H, straight=True); means.append(m)
        if k < 4 or k % 3: continue
        means = np.array(means)  # (n, H, 2)
        fut = np.transpose(tr[k+1:k+H+1], (1, 0, 2))
        E['straight'].append(np.hypot(*(means - fut).transpose(2, 0, 1)))
        for name in ('orca', 'orca_truestate'):
            if name == 'orca':
                v = (means[:, 1] - means[:, 0]) / T; p0 = means[:, 0] - v * T
            else:
                v = (tr[k] - tr[k-1]) / T; p0 = tr[k]
            specs = [types.SimpleNamespace(behaviour='orca', radius_m=0.3, position_m=p0[j], goal_m=p0[j] + v[j] / max(np.hypot(*v[j]), 1e-6) * 100,
                     preferred_speed_mps=max(float(np.hypot(*v[j])), 0.05), sees_robot=False) for j in range(n)]
            w = MoverWorld(specs, (), 0.35, ()); w._vel = v.copy(); w.advance(H * T)
            P = np.transpose(w.positions(np.arange(1, H + 1) * T), (1, 0, 2))
            E[name].append(np.hypot(*(P - fut).transpose(2, 0, 1)))
for name, e in E.items():
    e = np.concatenate(e)
    print(f"{name:15s} mean at steps 1,2,4,8,12: " + ' '.join(f"{e[:, s-1].mean():.3f}" for s in (1,2,4,8,12)) + "  p95: " + ' '.join(f"{np.percentile(e[:, s-1],95):.3f}" for s in (1,2,4,8,12)))
print([ (m.radius_m, m.preferred_speed_mps) for m in sc.moving[:3]])
