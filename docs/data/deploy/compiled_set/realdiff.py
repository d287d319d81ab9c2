"""Every crowd-network call of 10 reactive UCY cases (seed 1) answered both ways: the largest difference.
The compiled pass switched on here (it is an option, off by default)."""
import numpy as np
import nn_export.runtime.side_networks as sn
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
from nn_export.runtime.model_file import INPUT_NAME
diffs = []; bad = []
_init = sn.CrowdNetwork.__init__
sn.CrowdNetwork.__init__ = lambda self, path, preset, robot, main, compiled=True: _init(self, path, preset, robot, main, True)
orig = sn.CrowdNetwork.answer
def both(self, values):
    a = orig(self, values)
    self._run(); b = tuple(self._y[0, :2].tolist())
    d = max(abs(a[0] - b[0]), abs(a[1] - b[1])); diffs.append(d)
    if d > 1e-5: bad.append((d, a, b, list(values)))
    return a
sn.CrowdNetwork.answer = both
cfg = preset("improved")
s = Suite("ucy", 40, 1, 5, "orca")
for i in range(0, 40, 4):
    sc = s.scenario(i); simulate(sc, make(ControllerSpec("nn"), cfg, sc.robot), "nn")
d = np.array(diffs)
print(len(d), "calls: max diff", d.max(), "p99", np.percentile(d, 99), "over 1e-5:", len(bad))
for b in bad[:3]:
    v = np.array(b[3]); print(b[0], b[1], b[2], "max |x|", np.abs(v).max(), "nonfinite", (~np.isfinite(v)).sum())
