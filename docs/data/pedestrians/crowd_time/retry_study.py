"""How often the plan a tick chooses came from a warm start the SQP gave up on and fatrop solved again
(the decision's tail), and what the tick would have chosen without it."""
import sys, json, time, numpy as np
from scenarios.suites import Suite
from scenarios.simulator import simulate
from casadi_gpc.config import preset
from casadi_gpc.planner.gpc import GPCController
from gpcnav.controllers import ControllerSpec, make
from gpcnav.commands.common import for_run
ticks = []
orig = GPCController.solve_tick
def traced(self, tick):
    t = time.perf_counter()
    best, solved = orig(self, tick)
    dt = time.perf_counter() - t
    retry = [s for s in solved if " after " in (s.status or "")]
    ok = [s for s in solved if s.success]
    others = [s for s in ok if " after " not in (s.status or "")]
    chosen_retry = best is not None and " after " in (best.status or "")
    alt = min((s.cost for s in others), default=np.inf)
    ticks.append(dict(dt=dt, n=len(solved), retries=len(retry), retry_ok=sum(s.success for s in retry),
                      chosen_retry=chosen_retry, best=(best.cost if best is not None else np.nan), alt=alt,
                      retry_time=sum(s.solve_time_s for s in retry)))
    return best, solved
GPCController.solve_tick = traced
idxs = [int(a) for a in sys.argv[1].split(",")]
for i in idxs:
    sc = Suite("ucy", 452, 1, behaviour=sys.argv[2] if len(sys.argv) > 2 else "orca").scenario(i)
    cfg = for_run(preset("improved"), [sc])
    log = simulate(sc, make(ControllerSpec("gpc"), cfg, sc.robot), "gpc")
    print(sc.name, log.outcome, flush=True)
dt = np.array([t["dt"] for t in ticks]) * 1e3
r = [t for t in ticks if t["retries"]]
print("ticks", len(ticks), "solve_tick ms median %.2f p99 %.1f max %.1f" % (np.median(dt), np.percentile(dt, 99), dt.max()))
print("ticks with a retry", len(r), "retries", sum(t["retries"] for t in r), "succeeded", sum(t["retry_ok"] for t in r))
c = [t for t in r if t["chosen_retry"]]
print("ticks whose chosen plan is a retry's", len(c))
for t in c:
    print("   best %.4g  best without the retry %.4g  ratio %.3f  tick %.1f ms (retries %.1f ms)" % (t["best"], t["alt"], t["alt"] / t["best"] if t["best"] else np.nan, t["dt"] * 1e3, t["retry_time"] * 1e3))
rt = np.array([t["dt"] for t in r]) * 1e3
print("ticks with a retry: ms median %.1f max %.1f; share of ticks over 30 ms that had a retry: %d of %d" % (np.median(rt), rt.max(), sum(1 for t in ticks if t['dt'] > 0.03 and t['retries']), int((dt > 30).sum())))
