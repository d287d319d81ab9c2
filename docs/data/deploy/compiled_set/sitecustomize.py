"""GPCNAV_EXP_ORT=1: the set networks run by onnxruntime (compiled_set_networks=False), for A/B runs."""
import os
if os.environ.get("GPCNAV_EXP_ORT") == "1":
    import nn_export.runtime.side_networks as sn
    _init = sn.CrowdNetwork.__init__
    def _patched(self, path, preset, robot, main, compiled=True):
        _init(self, path, preset, robot, main, False)
    sn.CrowdNetwork.__init__ = _patched
