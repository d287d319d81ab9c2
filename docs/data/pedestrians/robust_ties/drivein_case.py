"""One UCY case of seed 1 (its index in the 452, the walkers: replay or orca, the controller), simulated again
with the shipped code, and the check's verdict at each of the last N decisions before its end.

    python drivein_case.py INDEX replay|orca gpc|nn N"""
import sys, numpy as np
from gpcnav.controllers import make, ControllerSpec
from gpcnav.commands.common import for_run
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
idx, beh, ctl = int(sys.argv[1]), sys.argv[2], sys.argv[3]
s = Suite("ucy", idx + 1, 1, 5, beh) if beh != "replay" else Suite("ucy", idx + 1, 1)
sc = s.scenario(idx)
cfg = for_run(preset('improved'), [sc])
pol = make(ControllerSpec(ctl), cfg, sc.robot)
flt = pol.filter; orig = flt.filter; verdicts = []
def f(*a, _o=orig, _v=verdicts, **k):
    v = _o(*a, **k); _v.append((a, v)); return v
flt.filter = f
log = simulate(sc, pol, ctl)
c = log.collision or {}
print(f"== {sc.name}: {log.outcome} t={c.get('time_s', float('nan')):.2f} v_to={c.get('robot_speed_towards_mps', float('nan')):.2f}")
k_end = len(log.decisions)
for k in range(max(0, k_end - int(sys.argv[4])), k_end):
    a, v = verdicts[k]; ch = v.check; d = log.decisions[k]
    print(f"t={log.t[k]:5.1f} cmd=({d.v_right_mps:5.2f},{d.v_left_mps:5.2f}) src={v.source:24s} reason={str(v.reason)}\n      safe={ch.safe!s:5s} clr={ch.min_clearance_m:6.2f} now={ch.current_clearance_m:5.2f} contact={ch.contact_s:5.2f} drives={ch.drives_in_s:5.2f} cont={ch.continuation}")
