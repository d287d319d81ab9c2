"""The rule's table (rule.md) from the runs' JSON documents: reached / collided (robot
approaching) / timed out per suite and variant, and the goals gained and lost episode by episode
with the exact one-sided sign test.

    python table.py DIR    # DIR holds SUITE-VARIANT.json for corridor, doorway, corner
"""
import json
import sys
from math import comb
from pathlib import Path

d = Path(sys.argv[1])
SUITES, VARIANTS = ("corridor", "doorway", "corner"), ("nn", "nn-sw", "gpc")
runs = {(s, v): json.loads((d / f"{s}-{v}.json").read_text())["episodes"] for s in SUITES for v in VARIANTS}


def tally(eps):
    out = [e["outcome"] for e in eps]
    appr = sum(1 for e in eps if e["outcome"] == "collided" and e["collision"].get("robot_speed_towards_mps", 0) > 0.05
               and e["collision"].get("obstacle_age_s", 0) >= 1.0)
    return out.count("reached_goal"), out.count("collided"), appr, out.count("timed_out")


print("| suite (seed 303, 60 with a pillar) | nn, shipped | nn, statics as walls | gpc (reference) |")
print("|---|---|---|---|")
tot = {v: [0, 0, 0, 0] for v in VARIANTS}
for s in SUITES:
    cells = []
    for v in VARIANTS:
        t = tally(runs[s, v])
        tot[v] = [a + b for a, b in zip(tot[v], t)]
        cells.append(f"{t[0]} / {t[1]} ({t[2]}) / {t[3]}")
    print(f"| {s} | " + " | ".join(cells) + " |")
print("| all 180 | " + " | ".join(f"{t[0]} / {t[1]} ({t[2]}) / {t[3]}" for t in tot.values()) + " |")
gained = lost = 0
for s in SUITES:
    a = {e["episode"]: e["outcome"] for e in runs[s, "nn"]}
    b = {e["episode"]: e["outcome"] for e in runs[s, "nn-sw"]}
    assert a.keys() == b.keys()
    gained += sum(a[i] != "reached_goal" and b[i] == "reached_goal" for i in a)
    lost += sum(a[i] == "reached_goal" and b[i] != "reached_goal" for i in a)
n = gained + lost
p = sum(comb(n, k) for k in range(gained, n + 1)) / 2 ** n if n else 1.0
print(f"\ngoals gained {gained}, lost {lost}; exact one-sided sign test p = {p:.4f}")
