import sys, collections, re
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
from gpcnav.controllers import ControllerSpec, make
from gpcnav.commands.common import for_run
s = Suite("ucy", 40, 1, 5, "orca")
names = sys.argv[1:]
tot = collections.Counter()
for i in range(40):
    sc = s.scenario(i)
    if names and sc.name not in names:
        continue
    ctl = make(ControllerSpec("nn"), for_run(preset("improved"), [sc]), sc.robot)
    log = simulate(sc, ctl, "nn")
    c = collections.Counter()
    prog = []
    for d in log.decisions:
        r = d.reason
        r = re.sub(r"[-+]?\d+(\.\d+)?", "#", r)
        c[r[:90]] += 1
    print(sc.name, log.outcome, len(log.decisions))
    for k, v in c.most_common(6):
        print("   ", v, k)
    tot.update(c)
print("TOTAL")
for k, v in tot.most_common(12):
    print("   ", v, k)
