"""Do people who see a robot that holds its ground show it before they reach it, and how
early? navground's Corridor runs along x, so a person's sideways (y) offset from the robot is
what avoiding it changes. A person walking at the robot: first measured within START_M of it
along the corridor, closing on it at more than 0.1 m/s (their x velocity over the last two
samples), with a sideways offset under OFFSET_M (0.8 m: the robot's 0.35 m and a person's 0.3
m, and 0.15 m). Followed while they close in; at each gap along the corridor in GAPS_M, how
much their sideways offset has opened since they were first seen (m). Then episode by
episode: the mean opening at GAP_M of the first K such people (by the time they reach it),
and the share of (see, blind) pairs of episodes that this mean orders right (AUC).

    python analyse.py SEE.json BLIND.json        (record.py's documents)
"""
import json
import sys

import numpy as np

T = 0.5
START_M, OFFSET_M = 5.0, 0.8
GAPS_M = (4.0, 3.5, 3.0, 2.5, 2.0, 1.5, 1.2)
GAP_M = 2.5


def encounters(ep):
    """Each person walking at the robot: their samples ``(t, gap along x, sideways offset)``."""
    rows, pos = ep["rows"], {}
    for k, (t, x, y, th, ms) in enumerate(rows):
        for i, mx, my in ms:
            if mx is not None:
                pos.setdefault(i, {})[k] = (t, mx, my)
    out = []
    for p in pos.values():
        series = []
        for k in sorted(p):
            t, mx, my = p[k]
            dx, dy = mx - rows[k][1], my - rows[k][2]
            if not series:
                if k - 2 in p and abs(dx) <= START_M and abs(dy) < OFFSET_M:
                    vx = (mx - p[k - 2][1]) / (2 * T)
                    if -vx * np.sign(dx) > 0.1:
                        series.append((t, abs(dx), abs(dy)))
                continue
            if abs(dx) < 0.05 or abs(dx) > series[-1][1] + 0.05:  # alongside, or no longer closing
                break
            series.append((t, abs(dx), abs(dy)))
        if series:
            out.append(series)
    return out


def opened(series, gap):
    """``(opening, time)`` when the person first came within ``gap`` along the corridor, else None."""
    for t, dx, dy in series:
        if dx <= gap:
            return dy - series[0][2], t
    return None


if __name__ == "__main__":
    sets = {}
    for path in sys.argv[1:3]:
        eps = json.load(open(path))
        name = path.split("/")[-1]
        encs = [s for e in eps for s in encounters(e)]
        outcomes = {o: sum(e["outcome"] == o for e in eps) for o in sorted({e["outcome"] for e in eps})}
        print(f"{name}: {len(eps)} episodes {outcomes}, {len(encs)} people walking at the robot")
        for g in GAPS_M:
            o = np.array([r[0] for s in encs if (r := opened(s, g)) is not None])
            q = np.percentile(o, [10, 25, 50, 75, 90])
            print(f"  gap {g:3.1f} m: n {len(o):3d}  opened by p10 {q[0]:+.2f} p25 {q[1]:+.2f} median {q[2]:+.2f} "
                  f"p75 {q[3]:+.2f} p90 {q[4]:+.2f} m | more than 0.1 m: {np.mean(o > 0.1):.2f}")
        sets[name] = [sorted((r for s in encounters(e) if (r := opened(s, GAP_M)) is not None), key=lambda z: z[1])
                      for e in eps]
    (na, see), (nb, blind) = sets.items()
    for k in (1, 2, 3):
        a = [np.mean([o for o, _ in v[:k]]) for v in see if len(v) >= k]
        b = [np.mean([o for o, _ in v[:k]]) for v in blind if len(v) >= k]
        when = [v[k - 1][1] for v in see if len(v) >= k]
        if a and b:
            auc = np.mean([(x > y) + 0.5 * (x == y) for x in a for y in b])
            print(f"first {k} at {GAP_M} m: {na} {len(a)} episodes, median {np.median(a):+.2f} m (person {k} there by "
                  f"{np.median(when):.1f} s) | {nb} {len(b)}, median {np.median(b):+.2f} m | AUC {auc:.2f}")
