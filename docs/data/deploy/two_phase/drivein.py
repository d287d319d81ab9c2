"""For each drive-in collision listed, re-simulate (the variant from the env) and print the
check's verdicts over the last decisions before the contact."""
import sys, os, numpy as np
from gpcnav.controllers import make, ControllerSpec
from gpcnav.commands.common import for_run
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
cases = [l.split() for l in sys.stdin if l.strip()]
for suite, movers, seed, count, name in cases:
    movers, seed, count = int(movers), int(seed), int(count)
    s = Suite(suite, count, seed, movers) if suite != "ucy" else Suite("ucy", count, seed)
    sc = next(s.scenario(i) for i in range(count) if s.scenario(i).name == name)
    cfg = for_run(preset('improved'), [sc])
    pol = make(ControllerSpec('gpc'), cfg, sc.robot)
    flt = pol.filter; orig = flt.filter; verdicts = []
    def f(*a, _o=orig, _v=verdicts, **k):
        v = _o(*a, **k); _v.append(v); return v
    flt.filter = f
    log = simulate(sc, pol, 'gpc')
    c = log.collision or {}
    print(f"== {name}: {log.outcome} t={c.get('time_s', float('nan')):.2f} v_to={c.get('robot_speed_towards_mps', float('nan')):.2f}")
    k_end = len(log.decisions)
    for k in range(max(0, k_end - 3), k_end):
        v = verdicts[k]; ch = v.check
        print(f"   t={log.t[k]:5.1f} src={v.source:28s} safe={ch.safe!s:5s} clr={ch.min_clearance_m:6.2f} now={ch.current_clearance_m:5.2f} contact={ch.contact_s:5.2f} drives={ch.drives_in_s:5.2f} cont={ch.continuation}")
