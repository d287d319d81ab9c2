"""c5 (rule3.md): the shipped walls network E trained further on a dataset whose open-building rounds keep the
GPC's labels and whose every other row (the suites', navground's corridor's, the sampled situations') is
labelled by E's own answer, so that it learns the open buildings and is held to E where E was trained
(learning without forgetting). E read back and trained as `gpcnav train --init` does (c3's and c4's
command: Adam, learning rate 1e-3, 30 epochs, patience 10, batches of 512, seed 0), saved as a model
folder for `gpcnav export`.

    python docs/data/buildings/walls_finetune/distil.py DATASET E.onnx OUT_MODEL_DIR

c6 (docs/data/buildings/walls_widths/): the same with c5 as the initial network, two datasets (comma-separated)
and the parts of other rounds that keep the GPC's labels too (a fourth argument, comma-separated):

    python docs/data/buildings/walls_finetune/distil.py out/wf/data,out/ww/data c5.onnx OUT gpc92,dagger93
"""
import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import onnxruntime as ort

from nn_export.training.dataset import load_dataset, read_manifest
from nn_export.training.train import WheelSpeedMLP
from nn_export.training.warm_start import read_set_network

OPEN_PARTS = ("gpc70", "dagger71", "dagger81", "dagger86")  # run.sh's rounds on open buildings

datasets, e_path, out = [Path(d) for d in sys.argv[1].split(",")], Path(sys.argv[2]), Path(sys.argv[3])
GPC_PARTS = OPEN_PARTS + (tuple(sys.argv[4].split(",")) if len(sys.argv) > 4 else ())
E = read_set_network(e_path)
sess = ort.InferenceSession(str(e_path), providers=["CPUExecutionProvider"])
parts = {data: sorted(read_manifest(data)["parts"]) for data in datasets}
X, Y, G, own = [], [], [], 0
for data in datasets:
    offset = 1 + max(int(g.max()) for g in G) if G else 0  # a later dataset's situation ids after the first's
    for part in parts[data]:
        d = load_dataset(data, (part,))
        if tuple(d.layout.feature_names) != tuple(E["feature_names"]):
            raise SystemExit(f"{data} {part}: another feature layout than E's")
        y = d.Y
        if part not in GPC_PARTS:  # E's own answer (the file's, clipped to the wheel limit as deployed)
            y = sess.run(None, {sess.get_inputs()[0].name: d.X.astype(np.float32)})[0].astype(np.float64)
            own += len(y)
        X.append(d.X)
        Y.append(y)
        G.append(d.groups + offset)
X, Y, G = np.concatenate(X), np.concatenate(Y), np.concatenate(G)
print(f"{len(X)} rows: {len(X) - own} with the GPC's labels ({', '.join(GPC_PARTS)}), {own} with E's answers",
      flush=True)
m = WheelSpeedMLP(hidden=E["hidden"], layers=E["layers"], architecture="set", encoder_width=E["encoder_width"],
                  activation=E["activation"], optimizer="adam", max_epochs=30, patience=10, batch_size=512,
                  learning_rate=1e-3, relative=True, random_state=0)
m.fit(X, Y, groups=G, feature_names=E["feature_names"], label_names=["v_right_mps", "v_left_mps"],
      init_state=E["state"])
meta = E["metadata"]
prov = {"preset": meta["preset"], "horizon": int(meta["horizon"]), "sample_time_s": float(meta["sample_time_s"]),
        "output": meta.get("output", "command"), "planner_config": json.loads(meta["planner_config"]),
        "robot": json.loads(meta["robot"]), "feature_layout": meta["feature_layout"],
        "feature_layout_version": int(meta["feature_layout_version"]),
        "feature_layout_spec": json.loads(meta["feature_layout_spec"]),
        "dataset": {"paths": [str(d) for d in datasets], "samples": int(len(X)),
                    "parts": {str(d): parts[d] for d in datasets}},
        "training": {"init": {"model": e_path.name, "sha256": hashlib.sha256(e_path.read_bytes()).hexdigest(),
                              "dataset": json.loads(meta.get("dataset") or "{}")},
                     "labels": f"the GPC's on {', '.join(GPC_PARTS)}; the initial network's own answers on the "
                               f"other parts (docs/data/buildings/walls_finetune/distil.py)"}}
m.save(out, prov, {"validation_features": X[m.validation_indices_]})
print(f"validation RMSE {np.sqrt(m.validation_mse_):.4f} m/s, best epoch {m.best_epoch_} ({m.stop_reason_}); "
      f"wrote {out}")
