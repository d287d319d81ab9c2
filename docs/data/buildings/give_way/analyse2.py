"""Does an approaching person's straight path turn away from where the robot is? The change
of the predicted miss distance (the straight path's closest approach to the robot's
position now) from one sample to the next, for people heading at the robot."""
import sys, json, math
from pathlib import Path
import numpy as np
sys.path.insert(0, str(Path(__file__).resolve().parent))
from analyse import tracks_of  # noqa: E402

T = 0.5

def miss(rel, v, horizon_s=4.0):
    vv = v @ v
    tc = min(max(-(rel @ v) / vv, 0.0), horizon_s) if vv > 1e-9 else 0.0
    return np.hypot(*(rel + tc * v))

def evidence(ep, until_s=1e9, dist_max=3.0, miss_max=1.0, lag=2):
    rows, tracks = tracks_of(ep, until_s)
    s = []
    for i, pos in tracks.items():
        for k in pos:
            if not all(j in pos for j in (k - lag, k + 1, k + 1 - lag)):
                continue
            r = np.array(rows[k][1:3])
            v0 = (pos[k] - pos[k - lag]) / (lag * T)
            rel0 = pos[k] - r
            if np.hypot(*rel0) > dist_max or -(v0 @ rel0) <= 0:
                continue
            m0 = miss(rel0, v0)
            if m0 > miss_max:
                continue
            v1 = (pos[k + 1] - pos[k + 1 - lag]) / (lag * T)
            s.append(miss(pos[k + 1] - r, v1) - m0)
    s = np.array(s)
    if len(s) < 2:
        return len(s), float("nan"), float("nan")
    return len(s), s.mean(), s.mean() / (s.std(ddof=1) / math.sqrt(len(s)))

sets = {p.split('/')[-1]: json.load(open(p)) for p in sys.argv[1:]}
for until in (10, 20, 1e9):
  for mm in (0.6, 1.0):
    line = []
    for f, eps in sets.items():
        ev = [evidence(e, until, 3.0, mm) for e in eps]
        z = np.array([c for _, _, c in ev]); mu = np.array([b for _, b, _ in ev]); n = np.array([a for a, _, _ in ev])
        line.append(f"{f[:9]}: n {np.median(n):3.0f} mu {np.nanmedian(mu) * 100:5.1f}cm z {np.nanmedian(z):5.2f} [{np.nanmin(z):5.2f},{np.nanmax(z):5.2f}]")
    print(f"until {until:>4.0f} miss<{mm}", ' | '.join(line))
