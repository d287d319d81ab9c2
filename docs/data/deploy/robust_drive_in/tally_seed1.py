import json, glob, os
def stats(eps, d):
    n=len(eps); rc=sum(e['outcome']=='reached_goal' for e in eps); col=sum(bool(e['collision']) for e in eps)
    ap=sum(1 for e in eps if e['collision'] and e['collision']['robot_speed_towards_mps']>0.05 and e['collision']['obstacle_age_s']>=1)
    return f"{rc}/{col}({ap})/{n-rc-col}"
def gpc_row(f):
    d=json.load(open(f))
    if 'controllers' in d:
        d=[c for c in d['controllers'] if c['controller']=='gpc'][0]
    return d
base = {'sq30':'docs/data/pedestrians/passive/gpc-sq30.json','sq20':'docs/data/pedestrians/passive/gpc-sq20.json',
        'corridor':'docs/data/buildings/compare200/corridor/COMPARE.json','doorway':'docs/data/buildings/compare200/doorway/COMPARE.json',
        'corner':'docs/data/buildings/compare200/corner/COMPARE.json','ucy':'docs/data/pedestrians/passive/gpc-ucy-replay-1.json',
        'ucyr':'docs/data/pedestrians/passive/gpc-ucy-orca-1.json',
        'held-replay':'docs/data/pedestrians/held_out_recordings/replay-stand-blind-gpc.json',
        'held-reactive':'docs/data/pedestrians/held_out_recordings/reactive-stand-blind-gpc-nn.json',
        'ng-corridor':'docs/data/buildings/navground-corridor/compare199/COMPARE.json'}
for name in ['sq30','sq20','corridor','doorway','corner','ucy','ucyr','circle5','circle10','square','randommulti','random','paper','held-replay','held-reactive','ng-corridor']:
    f = f'docs/data/deploy/robust_drive_in/seed1/gpc-s1-{name}.json' if os.path.exists(f'docs/data/deploy/robust_drive_in/seed1/gpc-s1-{name}.json') else f'docs/data/deploy/robust_drive_in/seed1/gpc-{name}.json'
    if not os.path.exists(f): print(name, '-'); continue
    d=json.load(open(f)); c=d['compute_time_s']
    b = ''
    if name in base and os.path.exists(base[name]):
        bd = gpc_row(base[name]); names_b=[e['scenario'] for e in bd['episodes_detail']]; names=[e['scenario'] for e in d['episodes_detail']]
        b = f"shipped {stats(bd['episodes_detail'], bd)} same-episodes={names_b==names}"
    print(f"{name:14s} new {stats(d['episodes_detail'], d):16s} med {c['median']*1e3:5.2f} p99 {c['p99']*1e3:5.1f} max {c['max']*1e3:5.0f} over {c['over_limit']} int/ep {d['interventions']/len(d['episodes_detail']):.2f} | {b}")
