"""Per tick: the jobs solved, warm or cold, each job's solver time, the tick's wall time.
The same arguments as gpc_parts.py."""
import sys, time, collections
from pathlib import Path
import numpy as np
sys.path.insert(0, str(Path(__file__).resolve().parent))
from gpc_parts import scenarios  # noqa: E402
from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.planner.gpc import GPCController  # noqa: E402
from gpcnav.commands.common import for_run  # noqa: E402
from gpcnav.controllers import ControllerSpec, make  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402

ticks = []
orig_sm = GPCController.solve_many
def solve_many(self, p, starts):
    t = time.perf_counter()
    out = orig_sm(self, p, starts)
    wall = time.perf_counter() - t
    ticks.append((wall, [(s[0], s[2] is not None) for s in starts], [(o.guess, o.solve_time_s, o.iterations, o.success) for o in out]))
    return out
GPCController.solve_many = solve_many
for sc in scenarios(sys.argv):
    cfg = for_run(preset("improved"), [sc])
    pol = make(ControllerSpec("gpc"), cfg, sc.robot)
    simulate(sc, pol, "gpc")
walls = np.array([t[0] for t in ticks]) * 1e3
print(f"{len(ticks)} solve_many calls; wall median {np.median(walls):.2f} ms p90 {np.percentile(walls, 90):.2f}")
nj = collections.Counter(len(t[1]) for t in ticks)
print("jobs per call", sorted(nj.items()))
warm = [s for t in ticks for (g, w), s in zip(t[1], t[2]) if w]
cold = [s for t in ticks for (g, w), s in zip(t[1], t[2]) if not w]
for name, rows in (("warm", warm), ("cold", cold)):
    ts = np.array([r[1] for r in rows]) * 1e3; it = np.array([r[2] for r in rows])
    print(f"{name}: {len(rows)} solves, time median {np.median(ts):.2f} ms mean {ts.mean():.2f} p90 {np.percentile(ts, 90):.2f}, iterations median {np.median(it)}, success {np.mean([r[3] for r in rows]):.3f}")
sums = np.array([sum(s[1] for s in t[2]) for t in ticks]) * 1e3
print(f"sum of solve times per call median {np.median(sums):.2f} ms; wall / sum median {np.median(walls / np.maximum(sums, 1e-9)):.2f}")
# critical path: per call, the largest single solve
mx = np.array([max([s[1] for s in t[2]] or [0]) for t in ticks]) * 1e3
print(f"largest single solve per call median {np.median(mx):.2f} ms; wall - largest median {np.median(walls - mx):.2f}")
