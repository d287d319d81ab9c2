"""Recorded people's tracks for the learned forecast (data.py's samples, from an ETH/UCY
recording instead of the simulator): everyone's position on the planner's 0.5 s grid (linear
between the recording's rows, as the replay moves them; absent outside their track),
measured with the suites' 0.02 m noise; with each sample's mirror image (y negated) too.

    python data_ucy.py OUT.npz RECORDING [RECORDING ...]   (a shipped name, or a file)
"""
import sys
from pathlib import Path

import numpy as np

from scenarios.recordings import SHIPPED, read_recording, shipped_recording
from data import PAST, T, pairs


def grid(rec) -> np.ndarray:
    """Positions ``(samples, people, 2)`` on the 0.5 s grid, NaN where a track is absent."""
    times = np.arange(rec.start_s, rec.end_s + 1e-9, T)
    out = np.full((len(times), len(rec.tracks), 2), np.nan)
    for j, tr in enumerate(rec.tracks):
        inside = (times >= tr[0, 0]) & (times <= tr[-1, 0])
        out[inside, j, 0] = np.interp(times[inside], tr[:, 0], tr[:, 1])
        out[inside, j, 1] = np.interp(times[inside], tr[:, 0], tr[:, 2])
    return out


def load(name: str):
    return shipped_recording(name) if name in SHIPPED else read_recording(name)


def samples(truth: np.ndarray, seed: int, mirror: bool = True):
    rng = np.random.default_rng(seed)
    X, Y = pairs(truth, truth + rng.normal(0.0, 0.02, truth.shape))
    if mirror:  # y negated: the own past's and the targets' odd entries, each neighbour's y and vy
        Xm, Ym = X.copy(), Y.copy()
        Xm[:, 1:2 * PAST:2] *= -1
        for n in range(8):
            o = 2 * PAST + 5 * n
            Xm[:, o + 2] *= -1
            Xm[:, o + 4] *= -1
        Ym[:, 1::2] *= -1
        X, Y = np.concatenate([X, Xm]), np.concatenate([Y, Ym])
    return X, Y


if __name__ == "__main__":
    out = sys.argv[1]
    parts = [samples(grid(load(n)), seed) for seed, n in enumerate(sys.argv[2:])]
    X = np.concatenate([p[0] for p in parts])
    Y = np.concatenate([p[1] for p in parts])
    rng = np.random.default_rng(0)
    order = rng.permutation(len(X))  # train.py holds out the last tenth: a random tenth here
    np.savez_compressed(out, X=X[order], Y=Y[order])
    print(out, X.shape)
