"""How often the planner tests a guess against the walls (guesses.meets_walls) and the time it takes a decision,
on corner seed 1's first 10 episodes. PYTHONPATH=REPO python per_decision.py"""
import time, numpy as np
import casadi_gpc.planner.guesses as g
import casadi_gpc.planner.multistart as ms
calls = [0]; tm = [0.0]
def wrap(f):
    def w(*a, **k):
        t = time.perf_counter(); r = f(*a, **k); tm[0] += time.perf_counter() - t; calls[0] += 1; return r
    return w
g.meets_walls = wrap(g.meets_walls)
from gpcnav.controllers import make, ControllerSpec
from gpcnav.commands.common import for_run
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
s = Suite("corner", 10, 1, 5, "orca"); dec = 0
for i in range(10):
    sc = s.scenario(i); cfg = for_run(preset("improved"), [sc])
    log = simulate(sc, make(ControllerSpec("gpc"), cfg, sc.robot), "gpc"); dec += len(log.decisions)
print(dec, "decisions;", calls[0], "meets_walls calls,", calls[0] / dec, "a decision;", tm[0] / dec * 1e3, "ms a decision")
