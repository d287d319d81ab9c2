"""The GPC behind its check with the check's trust time for its plans set to TRUST seconds
(the shipped: 3 s), on episodes LO..HI-1 of a wall suite with its walkers' BEHAVIOUR.

    python trust.py corridor social_force 1 0 40 6.0
"""
import pathlib, sys as _s; _s.path.insert(0, str(pathlib.Path(__file__).resolve().parents[4]))
import sys, numpy as np
from scenarios import Suite
from scenarios.simulator import simulate
from gpcnav.controllers import ControllerSpec, make
from gpcnav.commands.common import for_run
from casadi_gpc.config import preset
suite_name, beh, seed, lo, hi, trust = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5]), float(sys.argv[6])
suite = Suite(suite_name, hi, seed, 5, beh)
outs = []
for i in range(lo, hi):
    sc = suite.scenario(i)
    cfg = for_run(preset("improved"), [sc])
    pol = make(ControllerSpec("gpc"), cfg, sc.robot)
    pol.filter.trust_planner_s = trust
    log = simulate(sc, pol, "gpc")
    outs.append(log.outcome)
    print(i, log.outcome, flush=True)
print(suite_name, beh, trust, {o: outs.count(o) for o in ("reached_goal", "collided", "timed_out")})
