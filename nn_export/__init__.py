"""nn_export: the network side of gpcnav, on two floors.

- ``nn_export.runtime``: what the deployed policy runs, numpy and onnxruntime only (and the
  CasADi-free modules of ``casadi_gpc``, whose check and forecasts numba compiles): the policy (``runtime.policy``), the one feature
  definition (``runtime.layouts``, ``runtime.features``), the situation and its tracker
  (``runtime.situation``, ``runtime.tracker``).
- ``nn_export.training``: what only a training machine runs: the situation sampler, the GPC
  labels (CasADi), the datasets and their worker pool, on-policy rounds, training and
  export (torch, onnx), the network's benchmark rows. It imports the runtime, never the
  reverse.

``from nn_export import OnnxPolicy`` is the deployment path. Nothing is imported here, and
``OnnxPolicy`` itself is imported on first use, so importing the package for its features
does not load onnxruntime either. The shipped models are in ``nn_export/models/``.
"""
__all__ = ["OnnxPolicy", "shipped_model_path"]


def __getattr__(name):
    if name in ("OnnxPolicy", "shipped_model_path"):
        from .runtime import policy
        return getattr(policy, name)
    raise AttributeError(f"module 'nn_export' has no attribute {name!r}")
