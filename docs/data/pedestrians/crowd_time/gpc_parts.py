"""Where a GPC decision's time goes: wrappers around its parts, over scenario files or a suite.

    python gpc_parts.py 'FILES*.toml' N      # the first N files
    python gpc_parts.py suite:NAME:SEED:MOVERS:N"""
import sys, time, glob, collections, numpy as np
from gpcnav.controllers import make, ControllerSpec
from gpcnav.commands.common import for_run
from casadi_gpc.config import preset
from casadi_gpc.planner.gpc import GPCController
from casadi_gpc.safety.shield import Shield
from casadi_gpc.safety.filter import SafetyFilter
from scenarios.loader import load_scenario
from scenarios.suites import Suite
from scenarios.simulator import simulate

def scenarios(argv):
    """The scenarios named on the command line (see the module)."""
    if argv[1].startswith("suite:"):
        _, name, seed, movers, n = argv[1].split(":")
        return [Suite(name, int(n), int(seed), int(movers), "orca").scenario(i) for i in range(int(n))]
    return [load_scenario(f) for f in sorted(glob.glob(argv[1]))[:int(argv[2])]]


def main(argv):
    acc = collections.defaultdict(list)
    cur = {}
    def wrap(cls, name, label):
        f = getattr(cls, name)
        def w(*a, **k):
            t = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                cur[label] = cur.get(label, 0.0) + time.perf_counter() - t
        setattr(cls, name, w)
    wrap(GPCController, "estimate", "estimate")
    wrap(GPCController, "pose", "pose")
    wrap(GPCController, "solve_tick", "solve_tick")
    wrap(GPCController, "_alternatives", "alternatives")
    wrap(GPCController, "_decide", "planner total")
    wrap(SafetyFilter, "filter", "check")
    wrap(Shield, "decide", "decision")
    for sc in scenarios(argv):
        cfg = for_run(preset("improved"), [sc])
        pol = make(ControllerSpec("gpc"), cfg, sc.robot)
        orig = pol.decide
        def decide(o, orig=orig):
            cur.clear()
            d = orig(o)
            for k, v in cur.items():
                acc[k].append(v)
            acc["n"].append(1)
            return d
        pol.decide = decide
        simulate(sc, pol, "gpc")
    n = len(acc["decision"])
    print(f"{n} decisions")
    for k, v in acc.items():
        if k == "n":
            continue
        v = np.array(v) * 1e3
        print(f"{k:14s} calls {len(v):5d} median {np.median(v):6.2f} ms  mean {v.mean():6.2f}  p90 {np.percentile(v, 90):6.2f}  p99 {np.percentile(v, 99):6.2f}")


if __name__ == "__main__":
    main(sys.argv)
