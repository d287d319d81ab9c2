"""The rules' tables (rule.md, rule2.md) from a run folder: reached / collided (robot
approaching) / timed out, the decision median, for the shipped code and the change on each
case set, and episode by episode how many changed outcome.

    python tally.py seed404     # or seed505
"""
import json
import sys
from pathlib import Path

d = Path(sys.argv[1])
rows, changed = [], {}
for name in ("corridor", "doorway", "corner", "ng", "nearwall"):
    cells = []
    eps = {}
    for side in ("shipped", "change"):
        doc = json.loads((d / f"{side}-{name}.json").read_text())
        e = doc["episodes_detail"]
        out = [x["outcome"] for x in e]
        cells.append(f"{out.count('reached_goal')} / {out.count('collided')} ({doc['collided_robot_approaching']}) / "
                     f"{out.count('timed_out')}, {doc['compute_time_s']['median'] * 1e3:.2f} ms")
        eps[side] = {x["scenario"]: x["outcome"] for x in e}
    diff = sum(eps["shipped"][k] != eps["change"][k] for k in eps["shipped"])
    rows.append(f"| {name} | {cells[0]} | {cells[1]} | {diff} |")
print("| cases | shipped: reached / collided (approaching) / timed out, decision median | the change | episodes that changed outcome |")
print("|---|---|---|---|")
print("\n".join(rows))
