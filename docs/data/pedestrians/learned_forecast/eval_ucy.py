"""Offline on recorded people: evaluate.py's comparison (the EKF against the learned forecast,
the same people, the same measurements) over an ETH/UCY recording's people on the planner's
0.5 s grid (data_ucy.py's), measured with 0.02 m noise.

    python eval_ucy.py MODEL.onnx RECORDING [RECORDING ...]   (each reported, then all together)"""
import sys

import numpy as np
import onnxruntime as ort

from data_ucy import grid, load
from evaluate import STEPS, compare, report

if __name__ == "__main__":
    sess = ort.InferenceSession(sys.argv[1], providers=["CPUExecutionProvider"])
    allerr, allin = {"ekf": [], "learned": []}, {"ekf": [], "learned": []}
    for n, name in enumerate(sys.argv[2:]):
        tr = grid(load(name))
        Z = tr + np.random.default_rng(100 + n).normal(0.0, 0.02, tr.shape)
        err, inside = {"ekf": [], "learned": []}, {"ekf": [], "learned": []}
        compare(sess, tr, Z, err, inside)
        print(f"{name}: error (m) at steps {STEPS} (0.5 s each)")
        report(err, inside)
        for k in err:
            allerr[k] += err[k]
            allin[k] += inside[k]
    if len(sys.argv) > 3:
        print("all together")
        report(allerr, allin)
