"""nn_rule.md's runs: the deployed network's check, shipped and with robust_drive_in, seeds 4 and 5."""
import json, os, sys
D = sys.argv[1] if len(sys.argv) > 1 else "docs/data/deploy/robust_drive_in/nn_seeds45"
tot = {}
for seed in ['4', '5']:
    for name in ['sq30', 'sq20', 'corridor', 'doorway', 'corner', 'ucy', 'ucyr']:
        row = []
        for v in ['base', 'robust']:
            f = f'{D}/{v}-s{seed}-{name}.json'
            if not os.path.exists(f):
                row.append(f"{v}: -"); continue
            d = json.load(open(f)); eps = d['episodes_detail']; n = len(eps)
            rc = sum(e['outcome'] == 'reached_goal' for e in eps); col = sum(bool(e['collision']) for e in eps)
            ap = d['collided_robot_approaching']
            t = tot.setdefault(v, [0, 0, 0, 0]); t[0] += rc; t[1] += col; t[2] += n - rc - col; t[3] += ap
            row.append(f"{v}: {rc}/{col}({ap})/{n - rc - col} int/ep {d['interventions'] / n:.2f}")
        print(f"s{seed} {name:8s} " + " | ".join(row))
print("totals (reached, collided, timed out, approaching):", tot)
