"""navground's two-robot crossing (docs/navground/antipodal_gpc.yaml), runs 0..N-1, the GPC
agents' outcome, time to target and efficacy. python antipodal.py N (from the repository root;
the option was set in `improved` through a worktree for the second side)."""
import sys
import tempfile

from navground import sim

import casadi_gpc.config as c
import gpcnav.navground_plugin  # noqa: F401  (registers GPC)
from gpcnav.navground_runs import agent_runs

print("cold_start_gap", c.preset("improved").cold_start_gap, flush=True)
with tempfile.TemporaryDirectory() as d:
    e = sim.load_experiment(open("docs/navground/antipodal_gpc.yaml").read())
    e.save_directory = d
    e.run(number_of_runs=int(sys.argv[1]))
    for a in agent_runs(e.path):
        if a.behaviour == "GPC":
            print(a.run, a.agent, a.reached, a.collided, round(a.time_to_target_s, 1), round(a.efficacy, 3))
