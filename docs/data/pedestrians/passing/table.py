"""The rule's table (rule.md) from the two runs' EVAL documents: python table.py"""
import json
from pathlib import Path

HERE = Path(__file__).resolve().parent
SETS = ["corridor", "doorway", "corner", "sq20", "ucy-replay", "ucy-reactive", "navground-corridor"]


def counts(path):
    d = json.load(open(path))
    eps = d["episodes_detail"]
    r = sum(e["outcome"] == "reached_goal" for e in eps)
    c = sum(e["outcome"] == "collided" for e in eps)
    ct = d["compute_time_s"]
    return r, c, len(eps) - r - c, d["collided_robot_approaching"], ct["median"] * 1e3, ct["p99"] * 1e3, \
        d["events"].get("passing_tracks", 0)


tot = {k: [0, 0, 0, 0] for k in ("shipped", "option")}
print("| set | shipped: reached / collided (approaching) / timed out, median / p99 ms | option | forecasts held |")
print("|---|---|---|---|")
for s in SETS:
    row = []
    for k in ("shipped", "option"):
        p = HERE / k / f"{s}.json"
        if not p.exists():
            row.append(None)
            continue
        r, c, t, a, med, p99, held = counts(p)
        row.append((r, c, t, a, med, p99, held))
        for i, v in enumerate((r, c, t, a)):
            tot[k][i] += v
    cell = lambda x: "" if x is None else f"{x[0]} / {x[1]} ({x[3]}) / {x[2]}, {x[4]:.2f} / {x[5]:.1f}"
    print(f"| {s} | {cell(row[0])} | {cell(row[1])} | {'' if row[1] is None else row[1][6]} |")
for k, v in tot.items():
    print(f"{k}: reached {v[0]}, collided {v[1]} (approaching {v[3]}), timed out {v[2]}")
