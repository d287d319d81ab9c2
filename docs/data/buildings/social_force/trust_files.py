"""The same on scenario files (TRUST 0: the shipped check).

    python trust_files.py 6.0 $(ls out/ng-2001/*.toml | head -40)
"""
import pathlib, sys as _s; _s.path.insert(0, str(pathlib.Path(__file__).resolve().parents[4]))
import sys
from scenarios import load_scenario
from scenarios.simulator import simulate
from gpcnav.controllers import ControllerSpec, make
from gpcnav.commands.common import for_run
from casadi_gpc.config import preset
trust = float(sys.argv[1]); files = sys.argv[2:]
outs = []
for f in files:
    sc = load_scenario(f)
    cfg = for_run(preset("improved"), [sc])
    pol = make(ControllerSpec("gpc"), cfg, sc.robot)
    if trust > 0:
        pol.filter.trust_planner_s = trust
    log = simulate(sc, pol, "gpc")
    outs.append(log.outcome)
    print(sc.name, log.outcome, flush=True)
print("trust", trust, {o: outs.count(o) for o in ("reached_goal", "collided", "timed_out")})
