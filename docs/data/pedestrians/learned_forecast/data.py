"""Walkers' tracks for a learned forecast: the crowd suites' walkers (blind to the robot, so
their motion does not depend on it) moved by the simulator's own mover world, sample by
sample (0.5 s), measured with the suites' 0.02 m noise; one sample per walker and instant
with 8 past and 12 future positions in the scene.

    python data.py OUT.npz SEEDS (a range A-B) [suites...]

Each sample, in the walker's frame (origin at its measured position now, x along its
measured displacement over the last 2 s, or the world's x when it moved less than 5 cm):
its 8 previous measured positions (16), the K nearest other walkers within 6 m now
(present, position, velocity over the last interval: 5 each, nearest first), in a scene with
walls the walls as a 16-sector scan to 4 m from the walker in its frame (the walls network's
own scan, nn_export.runtime.wall_scan), and the target: its true positions at steps 1..12
less its measured position now (24).

    python data.py OUT.npz SEEDS [suite:movers:behaviour ...]   (the building suites read walls)"""
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from casadi_gpc.estimation.walls_forecast import HORIZON as H, NEIGHBOURS as K, PAST, SAMPLE_TIME_S as T, SECTORS
from casadi_gpc.estimation.walls_forecast import walker_features
from nn_export.runtime.wall_scan import wall_segment_rows

sys.path.insert(0, str(Path(__file__).resolve().parents[4] / "tools"))
from oracle_forecasts import true_positions  # noqa: E402
from scenarios import Suite  # noqa: E402

NO_WALLS = np.zeros((0, 4))
SUITES = [("square-crossing", 10, "orca"), ("square-crossing", 20, "orca"), ("square-crossing", 30, "orca"),
          ("square-crossing", 20, "social_force"), ("circle-crossing", 10, "orca"), ("circle-crossing", 5, "orca")]


def features(meas: np.ndarray, k: int, j: int, wall_rows=None) -> tuple[np.ndarray, float, float] | None:
    """The input of walker ``j`` at sample ``k`` from the measurements ``meas`` (samples,
    walkers, 2; NaN where absent), and its frame (cos, sin); None without 8 past positions.
    ``wall_rows``: the scene's wall segments (``wall_segment_rows``), scanned from the walker;
    without them, no scan. The planner's own features
    (:func:`casadi_gpc.estimation.walls_forecast.walker_features`, the one definition; until
    2026-11-30 written out here walker by walker, the same numbers within 1e-12)."""
    if k < PAST:
        return None
    X, c, s, kept = walker_features(meas[k - PAST:k + 1], [j], wall_rows if wall_rows is not None else NO_WALLS, T)
    if not kept:
        return None
    return (X[0] if wall_rows is not None else X[0, :2 * PAST + 5 * K]), float(c[0]), float(s[0])


def episode(job):
    name, seed, movers, behaviour, index = job
    sc = Suite(name, index + 1, seed, movers, behaviour).scenario(index)
    truth = true_positions(sc, T, H, hold_absent=False)
    walls = wall_segment_rows([w.points for w in sc.walls]) if sc.walls else None
    rng = np.random.default_rng([seed, index, movers, 17])
    return pairs(truth, truth + rng.normal(0.0, 0.02, truth.shape), walls)


def pairs(truth: np.ndarray, meas: np.ndarray, walls=None) -> tuple[np.ndarray, np.ndarray]:
    """Every sample of ``truth`` (``(samples, walkers, 2)``, NaN where absent) measured as
    ``meas``: the inputs (:func:`features`) and the targets, the true positions at steps
    1..12 less the measured one now, in the walker's frame."""
    X, Y = [], []
    for k in range(PAST, truth.shape[0] - H):
        for j in range(truth.shape[1]):
            fut = truth[k + 1:k + H + 1, j]
            if not np.isfinite(fut).all():
                continue
            f = features(meas, k, j, walls)
            if f is None:
                continue
            x, c, s = f
            R = np.array([[c, s], [-s, c]])
            X.append(x)
            Y.append(((fut - meas[k, j]) @ R.T).ravel())
    n_in = 2 * PAST + 5 * K + (SECTORS if walls is not None else 0)
    return np.array(X).reshape(-1, n_in), np.array(Y).reshape(-1, 2 * H)


if __name__ == "__main__":
    out, seeds = sys.argv[1], sys.argv[2]
    a, b = (int(v) for v in seeds.split("-"))
    suites = SUITES if len(sys.argv) <= 3 else [
        (n, int(m), beh) for n, m, beh in (s.split(":") for s in sys.argv[3:])]
    jobs = [(n, seed, m, beh, 0) for seed in range(a, b + 1) for n, m, beh in suites]
    with ProcessPoolExecutor(2) as ex:
        parts = list(ex.map(episode, jobs, chunksize=4))
    X = np.concatenate([p[0] for p in parts])
    Y = np.concatenate([p[1] for p in parts])
    np.savez_compressed(out, X=X, Y=Y)
    print(out, X.shape, Y.shape)
