"""The rule's table from the documents of judge.sh (argv[1]: the runs folder; default runs/ beside this file):
reached / collided (robot approaching) / timed out for each set and network, and the rule's sums.

    python docs/data/buildings/walls_finetune/table.py
"""
import json
import sys
from pathlib import Path

R = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).with_name("runs")
SETS = [("open buildings (scenes.py seed 8301, 60)", "open", "A"), ("one wall (gen.py seed 11, 40)", "onewall", "A"),
        ("corridor, seed 82 (200)", "corridor-s82", "B"), ("doorway, seed 82 (200)", "doorway-s82", "B"),
        ("corner, seed 82 (200)", "corner-s82", "B"), ("navground's corridor, seeds 7341-7440", "navground", "B")]
NETS = [("E (shipped)", "E"), ("c3 (E trained further)", "c3")]


def tally(doc):
    out = [e["outcome"] for e in doc["episodes_detail"]]
    return len(out), out.count("reached_goal"), out.count("collided"), int(doc["collided_robot_approaching"]), \
        out.count("timed_out")


rows, sums = [], {}
for label, key, group in SETS:
    cells = []
    for _, n in NETS:
        f = R / f"{n}-{key}.json"
        if not f.is_file():
            cells.append("(not run)")
            continue
        t = tally(json.loads(f.read_text()))
        s = sums.setdefault((group, n), [0, 0, 0, 0, 0])
        for i, v in enumerate(t):
            s[i] += v
        cells.append(f"{t[1]} / {t[2]} ({t[3]}) / {t[4]}")
    rows.append(f"| {label} | " + " | ".join(cells) + " |")
print("| cases | " + " | ".join(n for n, _ in NETS) + " |")
print("|---|" + "---|" * len(NETS))
print("\n".join(rows))
for g in ("A", "B"):
    print(f"| **sum {g}** | " + " | ".join(
        "{1} / {2} ({3}) / {4} of {0}".format(*sums[(g, n)]) if (g, n) in sums else "-" for _, n in NETS) + " |")
if all((g, n) in sums for g in "AB" for _, n in NETS):
    (_, ea, eca, _, _), (_, ca, cca, _, _) = sums[("A", "E")], sums[("A", "c3")]
    (_, eb, ecb, eab, _), (_, cb, ccb, cab, _) = sums[("B", "E")], sums[("B", "c3")]
    rule = {"1. A: at least 10 more goals, no collision": ca >= ea + 10 and cca == 0,
            "2. B: collisions no more": ccb <= ecb, "2. B: collisions approaching no more": cab <= eab,
            "2. B: goals no fewer": cb >= eb}
    for k, v in rule.items():
        print(f"- {k}: {'holds' if v else 'FAILS'}")
    print("adopted" if all(rule.values()) else "rejected")
