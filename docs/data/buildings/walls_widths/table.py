"""rule5.md's table and verdict from judge.sh's documents (runs/): reached / collided (robot approaching) / timed out.

    python docs/data/buildings/walls_widths/table.py          # the judged cases
    python docs/data/buildings/walls_widths/table.py gate     # the gate's development cases
"""
import json
import sys
from pathlib import Path

R = Path(__file__).with_name("runs")
GATE = len(sys.argv) > 1 and sys.argv[1] == "gate"
SETS = ([("widths, scenes.py seed 9301 (60)", "gate-widths", "A")]
        + [(f"{s}, seed 2 (20)", f"gate-{s}-s2", "B") for s in ("corridor", "doorway", "corner")] if GATE else
        [("A: widths, scenes.py seed 9401 (120)", "widths", "A")]
        + [(f"B: {s}, seed 85 (200)", f"{s}-s85", "B") for s in ("corridor", "doorway", "corner")]
        + [("B: navground's corridor, seeds 7641-7740", "navground", "B"),
           ("C: open buildings seed 8304 (60), one wall seed 14 (40)", "open", "C")])


def tally(name, key):
    doc = json.loads((R / f"{name}-{key}.json").read_text())
    out = [e["outcome"] for e in doc["episodes_detail"]]
    return [len(out), out.count("reached_goal"), out.count("collided"), int(doc["collided_robot_approaching"]),
            out.count("timed_out")]


sums = {}
print("| cases | c5 (shipped) | c6 |\n|---|---|---|")
for label, key, group in SETS:
    cells = []
    for net in ("c5", "c6"):
        t = tally(net, key)
        sums[(group, net)] = [a + b for a, b in zip(sums.get((group, net), [0] * 5), t)]
        cells.append("{1} / {2} ({3}) / {4}".format(*t))
    print(f"| {label} | " + " | ".join(cells) + " |")
for g in sorted({k[0] for k in sums}):
    print(f"| **sum {g}** | " + " | ".join("{1} / {2} ({3}) / {4} of {0}".format(*sums[(g, n)]) for n in ("c5", "c6"))
          + " |")
(n, ga, ca, _, ta), (_, gb, cb, _, tb) = sums[("A", "c5")], sums[("A", "c6")]
if GATE:
    rule = {"gate: fewer failures on the widths": cb + tb < ca + ta,
            "gate: no more collisions in the suites": sums[("B", "c6")][2] <= sums[("B", "c5")][2]}
else:
    (_, g5, c5, a5, _), (_, g6, c6, a6, _) = sums[("B", "c5")], sums[("B", "c6")]
    (_, o5, oc5, _, _), (_, o6, oc6, _, _) = sums[("C", "c5")], sums[("C", "c6")]
    rule = {"1. A: failures at most half of c5's": 2 * (cb + tb) <= ca + ta, "1. A: collisions no more": cb <= ca,
            "2. B: collisions no more": c6 <= c5, "2. B: collisions approaching no more": a6 <= a5,
            "2. B: goals at least c5's less 10": g6 >= g5 - 10,
            "3. C: no collision": oc6 == 0, "3. C: goals at least c5's less 5": o6 >= o5 - 5}
for k, v in rule.items():
    print(f"- {k}: {'holds' if v else 'FAILS'}")
print(("passed" if GATE else "adopted") if all(rule.values()) else ("gated out" if GATE else "rejected"))
