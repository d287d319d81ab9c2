"""The building suites with other dimensions (a robustness look, not a tuning set)."""
import sys, collections
import scenarios.building_suite as B
name, width, door, n = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
B.CORRIDOR_WIDTH_M, B.DOOR_WIDTH_M = width, door
from gpcnav.controllers import make, ControllerSpec
from gpcnav.commands.common import for_run
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
import numpy as np
from concurrent.futures import ProcessPoolExecutor
def one(i):
    B.CORRIDOR_WIDTH_M, B.DOOR_WIDTH_M = width, door
    sc = Suite(name, n, 11, 5, "orca").scenario(i)
    cfg = for_run(preset("improved"), [sc])
    log = simulate(sc, make(ControllerSpec(sys.argv[5] if len(sys.argv) > 5 else "gpc"), cfg, sc.robot), "x")
    return log.outcome, (log.collision or {}).get("obstacle"), float(np.median(log.compute_time_s))
with ProcessPoolExecutor(2) as ex:
    res = list(ex.map(one, range(n)))
print(name, width, door, collections.Counter(r[0] for r in res), collections.Counter(r[1] for r in res if r[1]),
      f"median of medians {np.median([r[2] for r in res]) * 1e3:.2f} ms")
