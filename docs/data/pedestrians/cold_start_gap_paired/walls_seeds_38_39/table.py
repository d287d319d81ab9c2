"""The rule's table (rule.md): python table.py OUTDIR (the run's documents, run.sh)."""
import json
import statistics
import sys
from pathlib import Path

out = Path(sys.argv[1])
rows, tot = [], {s: [0, 0, 0, 0] for s in ("shipped", "option")}
gained = lost = 0
for seed in (38, 39):
    for suite in ("corridor", "doorway", "corner"):
        docs = {s: json.loads((out / f"{suite}-{seed}-{s}.json").read_text()) for s in ("shipped", "option")}
        cells = []
        for s, d in docs.items():
            outc = [e["outcome"] for e in d["episodes_detail"]]
            r, c, t = outc.count("reached_goal"), outc.count("collided"), len(outc) - outc.count("reached_goal") - outc.count("collided")
            a = int(d["collided_robot_approaching"])
            med = statistics.median(e["compute_median_s"] for e in d["episodes_detail"]) * 1e3
            cells.append(f"{r} / {c} ({a}) / {t}, {d['compute_time_s']['median'] * 1e3:.2f} ms")
            for i, v in enumerate((r, c, a, t)):
                tot[s][i] += v
        by = {s: {e["scenario"]: e["outcome"] for e in d["episodes_detail"]} for s, d in docs.items()}
        for k, o in by["shipped"].items():
            n = by["option"][k]
            gained += o != "reached_goal" and n == "reached_goal"
            lost += o == "reached_goal" and n != "reached_goal"
        rows.append(f"| `{suite}`, seed {seed} (200) | {cells[0]} | {cells[1]} |")
print("| set | shipped: reached / collided (robot approaching) / timed out, decision median | cold_start_gap=1 |")
print("|---|---|---|")
print("\n".join(rows))
f = lambda v: f"{v[0]} / {v[1]} ({v[2]}) / {v[3]}"
print(f"| all (1 200) | {f(tot['shipped'])} | {f(tot['option'])} |")
print(f"\ngoals gained / lost by the option, episode by episode: +{gained} / -{lost}")
