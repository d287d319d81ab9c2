import sys, numpy as np
from scenarios.suites import Suite
from scenarios.simulator import simulate
from casadi_gpc.config import preset
from casadi_gpc.planner.gpc import GPCController
from gpcnav.controllers import ControllerSpec, make
from gpcnav.commands.common import for_run
seq = []
orig = GPCController.solve_tick
def traced(self, tick):
    best, solved = orig(self, tick)
    seq.append([(s.guess, " after " in (s.status or ""), s.iterations) for s in solved])
    return best, solved
GPCController.solve_tick = traced
for i in [int(a) for a in sys.argv[1].split(",")]:
    sc = Suite("ucy", 452, 1, behaviour="orca").scenario(i)
    cfg = for_run(preset("improved"), [sc])
    seq.append(None)
    simulate(sc, make(ControllerSpec("gpc"), cfg, sc.robot), "gpc")
prev = set(); n_retry = n_prev = 0; warm_after_retry = []; names = {}
for t in seq:
    if t is None:
        prev = set(); continue
    cur = {g for g, r, _ in t if r}
    for g, r, it in t:
        names[g] = names.get(g, 0) + 1
        if g in prev:
            warm_after_retry.append((r, it))
    n_retry += len(cur); n_prev += len(cur & prev)
    prev = cur
print("retries", n_retry, "of which the same start had a retry the tick before", n_prev)
w = warm_after_retry
print("solves of a start whose previous solve was a retry:", len(w), "retried again:", sum(r for r, _ in w),
      "SQP successes among them, iterations:", sorted(it for r, it in w if not r)[:40])
print("start names", names)
