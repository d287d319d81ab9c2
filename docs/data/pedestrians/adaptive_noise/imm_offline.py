"""Offline: an IMM (two CTRV EKFs: the shipped noise and a manoeuvre model) against the shipped
filter, the walkers' forecasts at 0.5 to 6 s. Usage: python imm_offline.py SUITE SEED MOVERS EPISODES"""
import sys, math, numpy as np
from dataclasses import replace
from pathlib import Path; _r = Path(__file__).resolve().parents[4]; sys.path[:0] = [str(_r), str(_r / 'tools')]
from oracle_forecasts import true_positions
from scenarios import Suite
from casadi_gpc.estimation.ekf import ObstacleEKF, EKFSettings
from casadi_gpc.estimation.obstacle_model import obstacle_model_step, _jacobian, _q_diagonal
T, H = 0.5, 12
suite, seed, movers, count = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
S0 = EKFSettings()
R = np.eye(2) * S0.measurement_std_m ** 2

def wrap(a): return (a + np.pi) % (2 * np.pi) - np.pi

class EKF:
    def __init__(self, st): self.Q = np.diag(_q_diagonal(st, T)); self.s = None; self.P = None
    def step(self, z):
        s, P = self.s, self.P
        F = _jacobian(s, T); s1 = obstacle_model_step(s, T); P1 = F @ P @ F.T + self.Q
        y = z - s1[:2]; S = P1[:2, :2] + R; Si = np.linalg.inv(S); K = P1[:, :2] @ Si
        self.s = s1 + K @ y; self.s[3] = wrap(self.s[3]); self.P = P1 - K @ P1[:2, :]
        self.P = 0.5 * (self.P + self.P.T)
        return math.exp(-0.5 * y @ Si @ y) / (2 * np.pi * math.sqrt(np.linalg.det(S)))

def second(z0, z1, st):
    d = z1 - z0; v = np.hypot(*d) / T; r = st.measurement_std_m ** 2
    var_th = min(np.pi ** 2, 2 * r / max(v * T, 1e-6) ** 2)
    return np.array([z1[0], z1[1], v, math.atan2(d[1], d[0]), 0.0]), np.diag([r, r, 2 * r / T ** 2, var_th, st.initial_turn_std_rad ** 2])

class IMM:
    def __init__(self, sets, Pi):
        self.f = [EKF(s) for s in sets]; self.Pi = np.asarray(Pi); self.mu = np.ones(len(sets)) / len(sets)
    def start(self, s, P):
        for f in self.f: f.s, f.P = s.copy(), P.copy()
    def step(self, z):
        n = len(self.f); c = self.Pi.T @ self.mu  # c_j = sum_i p_ij mu_i
        w = (self.Pi * self.mu[:, None]) / c[None, :]  # w[i, j] = mu_{i|j}
        xs = [f.s for f in self.f]; Ps = [f.P for f in self.f]
        new = []
        for j in range(n):
            ref = xs[j][3]
            x0 = sum(w[i, j] * np.r_[xs[i][:3], ref + wrap(xs[i][3] - ref), xs[i][4]] for i in range(n))
            P0 = np.zeros((5, 5))
            for i in range(n):
                d = np.r_[xs[i][:3], ref + wrap(xs[i][3] - ref), xs[i][4]] - x0
                P0 += w[i, j] * (Ps[i] + np.outer(d, d))
            new.append((x0, P0))
        L = np.zeros(n)
        for j, f in enumerate(self.f):
            f.s, f.P = new[j]; L[j] = f.step(z)
        mu = c * L; self.mu = mu / mu.sum() if mu.sum() > 0 else np.ones(n) / n
    def combined(self):
        ref = self.f[0].s[3]
        xs = [np.r_[f.s[:3], ref + wrap(f.s[3] - ref), f.s[4]] for f in self.f]
        x = sum(m * s for m, s in zip(self.mu, xs))
        return x

def straight(s):
    k = np.arange(1, H + 1)[:, None]
    return s[:2] + k * T * s[2] * np.array([math.cos(s[3]), math.sin(s[3])])

variants = {}
for k in (4, 8, 16):
    hi = replace(S0, speed_noise_mps2=S0.speed_noise_mps2 * k, heading_noise_rad=S0.heading_noise_rad * k)
    variants[f'imm_x{k}'] = ([S0, hi], [[0.95, 0.05], [0.10, 0.90]])
steps = [1, 2, 4, 8, 12]
names = ['ekf_shipped', 'ekf_mine'] + list(variants) + ['cv1true']
err = {n: [] for n in names}
rng = np.random.default_rng(5)
for idx in range(count):
    sc = Suite(suite, idx + 1, seed, movers).scenario(idx)
    tr = true_positions(sc, T, 0, hold_absent=False)[:int(sc.duration_s / T) + 1]
    K, n = tr.shape[0], tr.shape[1]
    Z = tr + rng.normal(0, 0.02, tr.shape)
    for j in range(n):
        ship = ObstacleEKF(T, S0); mine = EKF(S0); imms = {nm: IMM(*v) for nm, v in variants.items()}
        first = None
        for k in range(K - H):
            if not np.all(np.isfinite(tr[k:k + H + 1, j])): break
            z = Z[k, j]
            ship.step((float(z[0]), float(z[1])))
            if first is None: first = z; continue
            if mine.s is None:
                s, P = second(first, z, S0); mine.s, mine.P = s.copy(), P.copy()
                for im in imms.values(): im.start(s, P)
            else:
                mine.step(z)
                for im in imms.values(): im.step(z)
            if k < 4: continue
            fut = tr[k + 1:k + H + 1, j]
            m, _ = ship.predict(H, straight=True); err['ekf_shipped'].append(np.hypot(*(m - fut).T))
            err['ekf_mine'].append(np.hypot(*(straight(mine.s) - fut).T))
            for nm, im in imms.items(): err[nm].append(np.hypot(*(straight(im.combined()) - fut).T))
            v = tr[k, j] - tr[k - 1, j]; m = tr[k, j] + np.arange(1, H + 1)[:, None] * v
            err['cv1true'].append(np.hypot(*(m - fut).T))
print(f"{suite} seed {seed} movers {movers}, {count} episodes: mean position error (m) at steps {steps}")
for name, e in err.items():
    e = np.array(e); print(f"{name:12s} n={len(e):6d} " + ' '.join(f"{e[:, s - 1].mean():.3f}" for s in steps))
print("p95 at steps", steps)
for name, e in err.items():
    e = np.array(e); print(f"{name:12s} " + ' '.join(f"{np.percentile(e[:, s - 1], 95):.3f}" for s in steps))
