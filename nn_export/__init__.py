"""nn_export: the network side of gpcnav.

``from nn_export import OnnxPolicy`` is the deployment path: it needs numpy and onnxruntime
only (and the numpy-only modules of ``casadi_gpc``). The feature definition
(``nn_export.features``) is numpy only as well. Training and export (``nn_export.train``,
``nn_export.export``) need torch and onnx, the labels (``nn_export.labels``) CasADi; none
of them is imported here, and ``OnnxPolicy`` itself is imported on first use, so importing
the package for its features does not load onnxruntime either.
"""
__all__ = ["OnnxPolicy", "shipped_model_path"]


def __getattr__(name):
    if name in ("OnnxPolicy", "shipped_model_path"):
        from . import policy
        return getattr(policy, name)
    raise AttributeError(f"module 'nn_export' has no attribute {name!r}")
