"""How often a set network averages the two sides of an obstacle (docs/nn-crowds.md, "Averaging the two sides").

    python tools/side_averaging.py DATASET_DIR MODEL_DIR MODEL.onnx

On the model's validation situations (MODEL_DIR/validation_indices.npy, from `gpcnav train`)
where the GPC swerves (half wheel difference above 0.05 m/s) with an obstacle near (a present
slot within 2 m): the share where the network's swerve is less than a fifth of the GPC's (a
straight answer, the two sides averaged), and the share where it swerves the other way.
Needs the dataset the model was trained on (the indices refer to it, all parts in order).
"""
import sys

import numpy as np
from nn_export import OnnxPolicy
from nn_export.training.dataset import load_dataset
if len(sys.argv) != 4:
    print("usage: " + __doc__.strip().splitlines()[2].strip(), file=sys.stderr)
    sys.exit(2)
ds = load_dataset(sys.argv[1])
val = np.load(sys.argv[2] + "/validation_indices.npy")
pol = OnnxPolicy(sys.argv[3], preset="improved")
X, Y = ds.X[val], ds.Y[val]
P = pol.network(X)
s, n, w = pol.layout.set_slots
slots = X[:, s:s + n * w].reshape(len(X), n, w)
near = np.where(slots[..., 0] > 0, np.hypot(slots[..., 1], slots[..., 2]), np.inf).min(1) < 2.0
gt, nt = (Y[:, 0] - Y[:, 1]) / 2, (P[:, 0] - P[:, 1]) / 2
swerve = near & (np.abs(gt) > 0.05)
straight = swerve & (np.abs(nt) < 0.2 * np.abs(gt))
opposite = swerve & (np.sign(nt) != np.sign(gt)) & (np.abs(nt) > 0.2 * np.abs(gt))
print(f"validation samples {len(X)}, near an obstacle {near.sum()}, GPC swerving {swerve.sum()}: "
      f"network straight {straight.sum() / swerve.sum():.1%}, the other way {opposite.sum() / swerve.sum():.1%}")
