"""Offline: the learned forecast against the planner's own (the obstacle EKF, straight on as
``improved`` forecasts) on the same walkers, the same measurements: mean and 95th-percentile
error at steps 1, 2, 4, 8, 12 (0.5 to 6 s), and how often the truth falls within 1 and 2 of
each forecast's standard deviations (an isotropic Gaussian: 39 % and 86 %; the EKF's own
position covariance, its larger eigenvalue).

    python evaluate.py MODEL.onnx SUITE SEED MOVERS EPISODES [BEHAVIOUR]"""
import sys
from pathlib import Path

import numpy as np
import onnxruntime as ort

sys.path.insert(0, str(Path(__file__).resolve().parents[4] / "tools"))
from oracle_forecasts import true_positions  # noqa: E402
from scenarios import Suite  # noqa: E402
from casadi_gpc.estimation.ekf import ObstacleEKF, EKFSettings  # noqa: E402
from data import H, PAST, T, features  # noqa: E402
from nn_export.runtime.wall_scan import wall_segment_rows  # noqa: E402

STEPS = [1, 2, 4, 8, 12]


def compare(sess, tr, Z, err, inside, wall_rows=None):
    """Each person of ``tr`` (true positions, ``(samples, people, 2)``, NaN where absent),
    measured ``Z``, forecast by the EKF (run over their measurements from their first) and by
    the learned network, at every sample with 8 past and 12 future positions: errors and
    whether the truth falls within 1 and 2 deviations, appended to ``err`` and ``inside``.
    ``wall_rows``: the scene's walls, for a network that reads them."""
    K, n = tr.shape[:2]
    for j in range(n):
        f = ObstacleEKF(T, EKFSettings())
        started = False
        for k in range(K - H):
            if not np.isfinite(Z[k, j]).all():
                if started:
                    break
                continue
            started = True
            f.step((float(Z[k, j, 0]), float(Z[k, j, 1])))
            fut = tr[k + 1:k + H + 1, j]
            if not np.isfinite(fut).all():
                break
            ft = features(Z, k, j, wall_rows)
            if ft is None:
                continue
            x, c, s = ft
            m, cov = f.predict(H, straight=True)
            e = np.hypot(*(m - fut).T)
            lam = np.linalg.eigvalsh(cov)[:, -1]
            err["ekf"].append(e)
            inside["ekf"].append(np.stack([e <= np.sqrt(lam), e <= 2 * np.sqrt(lam)]))
            y = sess.run(None, {"x": x[None].astype(np.float32)})[0][0]
            R = np.array([[c, -s], [s, c]])  # back to the world frame
            ml = Z[k, j] + y[:2 * H].reshape(H, 2) @ R.T
            sd = np.exp(y[2 * H:])
            e = np.hypot(*(ml - fut).T)
            err["learned"].append(e)
            inside["learned"].append(np.stack([e <= sd, e <= 2 * sd]))


def main():
    model, suite, seed, movers, count = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
    behaviour = sys.argv[6] if len(sys.argv) > 6 else "orca"
    sess = ort.InferenceSession(model, providers=["CPUExecutionProvider"])
    rng = np.random.default_rng(5)
    err, inside = {"ekf": [], "learned": []}, {"ekf": [], "learned": []}
    for idx in range(count):
        sc = Suite(suite, idx + 1, seed, movers, behaviour).scenario(idx)
        tr = true_positions(sc, T, 0, hold_absent=False)[:int(sc.duration_s / T) + 1]
        walls = wall_segment_rows([w.points for w in sc.walls]) if sc.walls else None
        compare(sess, tr, tr + rng.normal(0, 0.02, tr.shape), err, inside, walls)
    print(f"{suite} {behaviour} seed {seed} movers {movers}, {count} episodes: error (m) at steps {STEPS}")
    report(err, inside)


def report(err, inside):
    for name, e in err.items():
        e, ins = np.array(e), np.array(inside[name])
        print(f"{name:8s} n={len(e):6d} mean " + " ".join(f"{e[:, s - 1].mean():.3f}" for s in STEPS)
              + " | p95 " + " ".join(f"{np.percentile(e[:, s - 1], 95):.3f}" for s in STEPS)
              + " | within 1 sd " + " ".join(f"{ins[:, 0, s - 1].mean():.2f}" for s in STEPS)
              + " | 2 sd " + " ".join(f"{ins[:, 1, s - 1].mean():.2f}" for s in STEPS))


if __name__ == "__main__":
    main()
