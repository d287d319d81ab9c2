"""A/B of two checkouts (one process each, alternated): the GPC on a wall suite's episodes; decision times and episode outcomes."""
import sys, json, subprocess, numpy as np
suite, n0, n1, repos = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4:]
child = r'''
import sys, json, numpy as np
from gpcnav.controllers import make, ControllerSpec
from gpcnav.commands.common import for_run
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
suite, n0, n1 = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
s = Suite(suite, n1, 1, 5, "orca"); ts = []; res = []
for i in range(n0, n1):
    sc = s.scenario(i); cfg = for_run(preset("improved"), [sc])
    log = simulate(sc, make(ControllerSpec("gpc"), cfg, sc.robot), "gpc"); ts += list(log.compute_time_s)
    res.append([log.outcome, len(log.decisions), float(log.min_clearance_m)])
print(json.dumps({"t": ts, "res": res}))
'''
out = {}
for rnd in range(int(__import__("os").environ.get("ROUNDS", "2"))):
    for r in repos:
        p = subprocess.run([sys.executable, "-c", child, suite, str(n0), str(n1)], capture_output=True, text=True,
                           env={"PYTHONPATH": r, "PATH": "/work/main/.venv/bin:/usr/bin:/bin", "HOME": "/root"})
        d = json.loads(p.stdout.strip().splitlines()[-1]); t = np.array(d["t"]) * 1e3
        print(f"round {rnd} {r}: {len(t)} decisions median {np.median(t):.2f} ms p99 {np.percentile(t, 99):.1f}", flush=True)
        out.setdefault(r, d["res"])
print("episodes the same to the bit:", all(out[repos[0]] == out[r] for r in repos))
