"""The bench's deployable decision closed loop, the first 10 episodes of its scene, with the
garbage collector as it is and frozen (gc.freeze() after setup, generation-0 threshold 50 000),
alternated, one process."""
import gc, sys, numpy as np
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
cfg = preset("improved")
suite = Suite("circle-crossing", 10, 1, 10, "orca")
scs = [suite.scenario(i) for i in range(10)]
pol = make(ControllerSpec("nn"), cfg, scs[0].robot)
simulate(scs[0], pol, "nn")  # warm-up (compiled code loaded)
default = gc.get_threshold()
res = {"as is": [], "frozen": []}
for rnd in range(3):
    for mode in ("as is", "frozen"):
        if mode == "frozen":
            gc.collect(); gc.freeze(); gc.set_threshold(50000, default[1], default[2])
        else:
            gc.unfreeze(); gc.set_threshold(*default)
        for sc in scs:
            log = simulate(sc, pol, "nn")
            res[mode] += list(np.array(log.compute_time_s) * 1e6)
for mode, v in res.items():
    v = np.array(v)
    print(f"{mode:7s} n={len(v)} median {np.median(v):.0f} us  p99 {np.percentile(v, 99):.0f}  max {v.max():.0f}  share over 1 ms {np.mean(v > 1000):.3f}")
