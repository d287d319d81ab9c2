"""The rule's table (rule.md) from a run folder: per set and side reached / collided (robot
approaching) / timed out, the decisions the walls network passed over, goals gained and lost
episode by episode; the rule's three conditions.

    python table.py RUNS > table.md
"""
import json
import sys
from pathlib import Path

from scipy.stats import binomtest

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))
from scenarios.paired import outcome_changes  # noqa: E402

d = Path(sys.argv[1])
SETS = ["ng", "corridor", "doorway", "corner", "corridor-12", "doorway-12", "corner-12"]
print("| set (the network behind its planner-free check) | shipped: reached / collided (approaching) / timed out |"
      " the change | decisions passed over | goals gained / lost |")
print("|---|---|---|---|---|")
tot = {"shipped": [0, 0], "change": [0, 0], "gained": 0, "lost": 0}
for name in SETS:
    cells, eps, over = [], {}, ""
    for side in ("shipped", "change"):
        f = d / f"{side}-{name}.json"
        if not f.is_file():
            cells.append("not run")
            continue
        doc = json.loads(f.read_text())
        e = doc["episodes_detail"]
        out = [x["outcome"] for x in e]
        cells.append(f"{out.count('reached_goal')} / {out.count('collided')} ({doc['collided_robot_approaching']}) / "
                     f"{out.count('timed_out')}")
        eps[side] = e
        tot[side][0] += out.count("collided")
        tot[side][1] += doc["collided_robot_approaching"]
        if side == "change":
            over = str(doc["events"].get("walls_network_passed_over", 0))
    gl = ""
    if len(eps) == 2:
        g, l = outcome_changes(eps["shipped"], eps["change"])["reached_goal"]
        tot["gained"] += g
        tot["lost"] += l
        gl = f"+{g} / -{l}"
    print(f"| {name} | {cells[0]} | {cells[1]} | {over} | {gl} |")


def p_lost(g: int, l: int) -> float:
    """One-sided exact sign test: P(at least l of n = g + l changes are losses | fair coin)."""
    return float(binomtest(l, g + l, 0.5, alternative="greater").pvalue) if g + l else 1.0


p = p_lost(tot["gained"], tot["lost"])
conds = [
    (f"1. the network's collisions {tot['shipped'][0]} -> {tot['change'][0]}", tot["change"][0] <= tot["shipped"][0]),
    (f"2. with the robot approaching {tot['shipped'][1]} -> {tot['change'][1]}", tot["change"][1] <= tot["shipped"][1]),
    (f"3. goals +{tot['gained']} / -{tot['lost']}, one-sided sign test p = {p:.3f}", p >= 0.1),
]
print()
for text, ok in conds:
    print(f"- {text}: {'holds' if ok else 'FAILS'}")
print(f"\n{'Adopted' if all(ok for _, ok in conds) else 'Rejected'} by the rule.")
