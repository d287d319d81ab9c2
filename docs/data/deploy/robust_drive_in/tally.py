import json, os, sys
forms = sys.argv[1].split(",") if len(sys.argv) > 1 else ["R", "RT"]
names = ['sq30','corner','corridor','sq20','doorway','ucy','ucyr']
def load(f):
    if not os.path.exists(f): return None
    d = json.load(open(f)); eps = d['episodes_detail']; n = len(eps)
    rc = sum(e['outcome']=='reached_goal' for e in eps); col = sum(bool(e['collision']) for e in eps)
    return rc, col, n-rc-col, d['collided_robot_approaching'], d['interventions']/n, d['compute_time_s']['median']*1e3
tot = {}
for seed in ['4','5']:
    for name in names:
        row = []
        for form in ['base'] + forms:
            f = f'docs/data/deploy/two_phase/gpc_seeds45/base-s{seed}-{name}.json' if form == 'base' else f'docs/data/deploy/robust_drive_in/seeds45/{form}-s{seed}-{name}.json'
            r = load(f)
            if r is None: row.append(f"{form}: -"); continue
            if load(f'out/rdi/{forms[0]}-s{seed}-{name}.json') is not None or form != 'base':
                t = tot.setdefault(form, [0,0,0,0])
                for i in range(4): t[i] += r[i]
            row.append(f"{form}: {r[0]}/{r[1]}({r[3]})/{r[2]} int {r[4]:.2f} med {r[5]:.2f}")
        print(f"s{seed} {name:8s} " + " | ".join(row))
print("totals where R ran (reached, collided, timed out, approaching):", tot)
