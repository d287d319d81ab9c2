"""Condition 4 of rule.md: the suites as they are (no static obstacle) decide the same with the
option on and off: ``COUNT`` episodes of ``SUITE`` (seed ``SEED``), the deployed network as
``gpcnav evaluate --controller nn`` makes it, outcome, steps, interventions and smallest
clearance compared to the bit, and every decision's command.

    python unchanged.py corridor 40 1
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))

from casadi_gpc.config import preset  # noqa: E402
from gpcnav.commands.common import for_run  # noqa: E402
from gpcnav.controllers import ControllerSpec, make  # noqa: E402
from scenarios import Suite  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402

suite_name, count, seed = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
suite = Suite(suite_name, count, seed, 5, "orca")
same = 0
for i in range(count):
    sc = suite.scenario(i)
    cfg = for_run(preset("improved"), [sc])
    logs = []
    for on in (False, True):
        pol = make(ControllerSpec("nn"), cfg, sc.robot)
        pol.policy.statics_as_walls = on
        logs.append(simulate(sc, pol, "nn"))
    a, b = logs
    key = lambda g: (g.outcome, len(g.decisions), g.events.get("interventions", 0), float(g.min_clearance_m),
                     [(d.v_right_mps, d.v_left_mps) for d in g.decisions])
    same += key(a) == key(b)
    print(i, a.outcome, key(a) == key(b), flush=True)
print(f"{suite_name} seed {seed}: {same} of {count} episodes the same with the option on and off")
