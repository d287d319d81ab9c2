"""Interleaved on the same cases, two worker processes (gpcnav.commands.evaluate.run_episodes): the GPC with two solve
lanes a worker, then one, REPS times; prints and writes each run's decision median, p99, max and outcomes.

    python lanes_alt.py "FOLDER/*.toml" REPS OUT.json
    python lanes_alt.py suite:square-crossing:30:1:40 REPS OUT.json
"""
import sys, json, glob, numpy as np
from casadi_gpc.config import preset
from casadi_gpc.pool import WorkerPool
from scenarios import load_scenario
from gpcnav.commands.common import for_run
from gpcnav.commands.evaluate import run_episodes
from gpcnav.controllers import ControllerSpec
reps = int(sys.argv[2])
if sys.argv[1].startswith("suite:"):
    from scenarios import Suite
    _, name, movers, seed, count = sys.argv[1].split(":")
    su = Suite(name, int(count), int(seed), int(movers), "orca")
    scs = [su.scenario(i) for i in range(int(count))]
else:
    scs = [load_scenario(f) for f in sorted(glob.glob(sys.argv[1]))]
base = for_run(preset("improved"), scs)
out = {}
for r in range(reps):
    for lanes in (2, 1):
        cfg = base.with_overrides(solve_lanes=lanes)
        metrics, times, events = run_episodes(scs, [ControllerSpec("gpc")], cfg, WorkerPool(2), desc=f"lanes {lanes}")[0]
        t = np.array(times) * 1e3
        row = dict(lanes=lanes, rep=r, median=float(np.median(t)), p99=float(np.percentile(t, 99)), max=float(t.max()),
                   n=len(t), outcomes=[m.outcome for m in metrics])
        out.setdefault(str(lanes), []).append(row)
        print(json.dumps({k: v for k, v in row.items() if k != "outcomes"}), flush=True)
json.dump(out, open(sys.argv[3], "w"), indent=1)
