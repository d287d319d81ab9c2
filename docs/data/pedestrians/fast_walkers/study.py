"""How often a second gated-out measurement is a pair the filter would take for a manoeuvre,
by the shipped test (within reach of the pending one) and by the velocity-aware one (within
reach of the segment from the pending one to it moved on by the track's own step), on the
recordings' tracks sampled every 0.5 s with 0.02 m noise. Both tests are judged on the
filter as it runs; run on the shipped code (study.txt: a worktree of c853f1e):

    cd BASE && PYTHONPATH=BASE python study.py /work/main/scenarios/recordings/*.gz out/held/raw/*.txt
"""
import sys, math, numpy as np
from scenarios.recordings import read_recording
from casadi_gpc.estimation.ekf import ObstacleEKF, EKFSettings
files = sys.argv[1:]
T = 0.5
rng = np.random.default_rng(0)
for f in files:
    rec = read_recording(f)
    n_pairs = old = new = fast = 0
    speeds = []
    for tr in rec.tracks:
        ts = np.arange(tr[0, 0], tr[-1, 0] + 1e-9, T)
        if len(ts) < 4: continue
        xs, ys = np.interp(ts, tr[:, 0], tr[:, 1]), np.interp(ts, tr[:, 0], tr[:, 2])
        speeds += list(np.hypot(np.diff(xs), np.diff(ys)) / T)
        ekf = ObstacleEKF(T, EKFSettings())
        reach = ekf.settings.max_maneuver_mps * T
        for x, y in zip(xs, ys):
            z = (float(x + rng.normal(0, 0.02)), float(y + rng.normal(0, 0.02)))
            pend = ekf.pending_z_
            s0 = ekf._s
            if pend is not None and s0 is not None and ekf.measurements_seen_ >= 2:
                # would this measurement be gated out? run a copy
                import copy
                e2 = copy.deepcopy(ekf)
                ev = e2.step(z)
                if ev in ("outlier", "manoeuvre", "start"):
                    n_pairs += 1
                    x0, y0, v, th, dth = s0
                    dx, dy = v * T * math.cos(th + dth), v * T * math.sin(th + dth)
                    ex, ey = z[0] - pend[0], z[1] - pend[1]
                    L2 = dx * dx + dy * dy
                    u = min(1.0, max(0.0, (ex * dx + ey * dy) / L2)) if L2 > 0 else 0.0
                    dseg = math.hypot(ex - u * dx, ey - u * dy)
                    o = math.hypot(ex, ey) <= reach
                    nw = dseg <= reach
                    old += o; new += nw; fast += (nw and not o)
            ekf.step(z)
    print(f"{rec.name}: tracks {len(rec.tracks)}, speed p50/p90/p99 {np.percentile(speeds,[50,90,99]).round(2)}, "
          f"second rejections {n_pairs}: a manoeuvre by the shipped test {old}, by the velocity-aware {new} ({fast} only by it)")
