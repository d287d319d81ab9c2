"""Export a trained network folder (from ``gpcnav train``) to one ONNX file, with the
normalisation and the wheel-speed clip inside the graph and the training provenance in its
metadata; checked with onnx.checker and against the torch model (parity within 1e-5 m/s)."""
from __future__ import annotations

import sys
from pathlib import Path

from ..errors import UsageError
from .common import check_output_files, same_file

def add_arguments(p):
    p.add_argument("model_dir", type=Path, help="folder written by `gpcnav train`")
    p.add_argument("--out", type=Path, required=True, help="write the ONNX model here")
    p.add_argument("--passes", type=int, choices=(1, 2), default=2,
                   help="how the policy runs this network by default: 2, the paper's two passes (default), or 1, "
                        "one pass with the real reference (docs/nn.md)")


def run(args) -> int:
    check_output_files(out=args.out)  # a folder, or a path that cannot be written: a traceback after the work
    if not (args.model_dir / "model.json").is_file():
        raise UsageError(f"{args.model_dir}: not a trained model folder (no model.json; run `gpcnav train` first)")
    # a file of the trained folder itself (--out M/model.json wrote the ONNX bytes over the model it had just
    # read, which no command could load again): any file there but an earlier export, whatever train writes
    if args.out.is_file() and args.out.suffix != ".onnx" and same_file(args.out.parent, args.model_dir):
        raise UsageError(f"--out {args.out} is the trained model's {args.out.name} in {args.model_dir}: it would be "
                         f"overwritten (name the ONNX file, e.g. {args.model_dir / 'model.onnx'})")
    try:
        from nn_export.training.export import export_onnx
        from nn_export.training.train import WheelSpeedMLP
    except ImportError as exc:
        raise UsageError(f"export needs the train extra (pip install -e '.[train]'): {exc}") from None
    try:
        model = WheelSpeedMLP.load(args.model_dir)
    except (ValueError, KeyError, OSError) as exc:
        raise UsageError(f"{args.model_dir}: cannot load the trained model: {exc}") from None
    parity_X = _validation_features(args.model_dir, model)
    try:
        report = export_onnx(model, args.out, parity_X, decision_passes=args.passes)
    except ValueError as exc:
        raise UsageError(f"{args.model_dir}: {exc}") from None
    meta = report["metadata"]
    print(f"wrote {report['path']} ({report['bytes']} bytes): layout {meta['feature_layout']} "
          f"v{meta['feature_layout_version']}, {meta['n_features']} inputs, preset {meta['preset']}, "
          f"{meta['decision_passes']} pass(es), validation RMSE {float(meta['validation_rmse_mps']):.4f} m/s, ONNX/torch parity "
          f"{report['parity_max_abs_mps']:.2e} m/s on {report['parity_samples']} validation samples", file=sys.stdout)
    return 0


def _validation_features(model_dir: Path, model):
    """The validation split's features, saved beside the model by ``gpcnav train``."""
    import numpy as np
    path = model_dir / "validation_features.npy"
    try:
        return np.load(path, allow_pickle=False) if path.is_file() else None
    except (ValueError, EOFError, OSError) as exc:  # (cut short: a traceback)
        raise UsageError(f"{model_dir}: cannot load the trained model: {path.name}: not a readable array "
                         f"({exc})") from None
