import sys, tempfile
from navground import sim
import gpcnav.navground_plugin
from gpcnav.navground_runs import agent_runs
import casadi_gpc, casadi_gpc.config as c
print(casadi_gpc.__file__, c.preset("improved").cold_start_gap, flush=True)
text = open("/work/main/docs/navground/antipodal_gpc.yaml").read()
runs = int(sys.argv[1]); start = int(sys.argv[2]) if len(sys.argv) > 2 else 0
with tempfile.TemporaryDirectory() as d:
    e = sim.load_experiment(text)
    e.save_directory = d
    e.run_index = start
    e.run(number_of_runs=runs, start_index=start) if False else e.run(number_of_runs=runs)
    for a in agent_runs(e.path):
        if a.behaviour == "GPC":
            print(a.run if hasattr(a, "run") else "", a.agent, a.reached, a.collided, round(a.time_to_target_s, 1), round(a.efficacy, 3), flush=True)
