"""Per episode: do the people walking at the robot turn away from it? The mean of each
approaching person's deviation from its own constant velocity, along the direction away
from the robot, and its z-score; by set."""
import sys, json, math
import numpy as np

T = 0.5
R_ROBOT = 0.35

def tracks_of(ep, until_s=1e9):
    """The episode's rows up to ``until_s``, and each person's measured positions by sample
    index: ``(rows, {id: {k: xy}})``."""
    rows = [r for r in ep["rows"] if r[0] <= until_s]
    tracks = {}
    for k, (t, x, y, th, ms) in enumerate(rows):
        for i, mx, my in ms:
            if mx is not None:
                tracks.setdefault(i, {})[k] = np.array([mx, my])
    return rows, tracks


def evidence(ep, until_s=1e9, dist_max=3.0, closing_min=0.1, miss_max=1.2, horizon_s=4.0):
    rows, tracks = tracks_of(ep, until_s)
    s = []
    for i, pos in tracks.items():
        for k in pos:
            if not all(j in pos for j in (k - 2, k - 1, k + 1)):
                continue
            m, v = pos[k], (pos[k] - pos[k - 2]) / (2 * T)
            r = np.array(rows[k][1:3])
            rel = m - r
            d = np.hypot(*rel)
            if d > dist_max or d < 1e-6:
                continue
            u = rel / d
            closing = -(v @ u)
            if closing < closing_min:
                continue
            # the person's straight path's closest approach to where the robot is now
            vv = v @ v
            tc = min(max(-(rel @ v) / vv, 0.0), horizon_s) if vv > 1e-9 else 0.0
            miss = np.hypot(*(rel + tc * v))
            if miss > miss_max:
                continue
            e = pos[k + 1] - (m + v * T)
            s.append(e @ u)
    s = np.array(s)
    if len(s) < 2:
        return len(s), float("nan"), float("nan")
    return len(s), s.mean(), s.mean() / (s.std(ddof=1) / math.sqrt(len(s)))

if __name__ == "__main__":
    for path in sys.argv[1:]:
        eps = json.load(open(path))
        for until in (10, 20, 40, 1e9):
            ev = [evidence(e, until) for e in eps]
            n = np.array([a for a, _, _ in ev]); mu = np.array([b for _, b, _ in ev]); z = np.array([c for _, _, c in ev])
            ok = np.isfinite(z)
            print(f"{path.split('/')[-1]:14s} until {until:>5.0f}s: samples median {np.median(n):5.0f} | mean dev "
                  f"{np.nanmedian(mu) * 100:6.2f} cm | z median {np.nanmedian(z):5.2f} min {np.nanmin(z) if ok.any() else float('nan'):5.2f} "
                  f"max {np.nanmax(z) if ok.any() else float('nan'):5.2f} | z>2: {int((z[ok] > 2).sum())}/{len(z)}  z<1: {int((z[ok] < 1).sum())}")
