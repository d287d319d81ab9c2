"""The rule's tally (rule.md): reached / collided (robot approaching) / timed out for the
shipped check (base) and W over out/ws/*.json, or the folder given."""
import json
import sys
from pathlib import Path

folder = Path(sys.argv[1] if len(sys.argv) > 1 else "out/ws")
total = {}
for name in ("s7-corridor", "s7-doorway", "s7-corner", "ng-corridor"):
    row = []
    for form in ("base", "W"):
        p = folder / f"{form}-{name}.json"
        if not p.exists():
            row.append(f"{form}: not run")
            continue
        d = json.loads(p.read_text())
        det = d["episodes_detail"]
        n = {o: sum(e["outcome"] == o for e in det) for o in ("reached_goal", "collided", "timed_out")}
        a = d["collided_robot_approaching"]
        t = total.setdefault(form, [0, 0, 0, 0])
        for i, v in enumerate((n["reached_goal"], n["collided"], a, n["timed_out"])):
            t[i] += v
        walls = sum(1 for e in det if e["outcome"] == "collided" and "wall" in str(e.get("collision")))
        row.append(f"{form}: {n['reached_goal']} / {n['collided']} ({a}; wall {walls}) / {n['timed_out']}"
                   f"  median {d['compute_time_s']['median'] * 1e3:.2f} ms p99 {d['compute_time_s']['p99'] * 1e3:.1f}")
    print(f"{name:12s}", " | ".join(row))
for form, (r, c, a, t) in total.items():
    print(f"total {form}: {r} / {c} ({a}) / {t}")
