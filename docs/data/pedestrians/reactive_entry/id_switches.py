"""Of the collisions with people under 1 s in the scene (all 452 replayed cases), how many are
an identity switch: a track that ended in the 1.2 s before, carried on at its last velocity,
within 1 m of where the newcomer appears. Run from the repository root: python
docs/data/pedestrians/reactive_entry/id_switches.py"""
import json, numpy as np
from scenarios.suites import Suite
d=json.load(open('docs/data/pedestrians/reactive_entry/COMPARE-all-452-replay.json'))
res={c['controller']:{e['scenario']:e for e in c['episodes_detail']} for c in d['controllers']}
s = Suite("ucy", 452, 1, 5, "replay")
names = {s.scenario(i).name: i for i in range(452)}
for ctl in ('gpc','stand'):
    n=sw=0
    for name, e in res[ctl].items():
        c=e['collision']
        if not c or c['obstacle_age_s']>=1: continue
        sc=s.scenario(names[name]); m=sc.moving[c['index']]
        t0=m.start_s; p0=m.xy_m[0]
        n+=1
        found=False
        for j,o in enumerate(sc.moving):
            if j==c['index']: continue
            te=o.end_s
            if t0-1.2 <= te <= t0+0.01:
                v=o.recorded_velocity_at(te-1e-6)
                pe=o.xy_m[-1]+v*(t0-te)
                if np.hypot(*(pe-p0))<1.0: found=True; break
        sw+=found
    print(ctl, 'ghost collisions', n, 'a track ended within 1.2 s before, its extrapolation within 1 m of the newcomer', sw)
