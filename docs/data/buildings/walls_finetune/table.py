"""The rule's table from the documents of judge.sh: reached / collided (robot approaching) / timed out for each
set and network, and the rule's sums. argv: the runs folder (default runs/ beside this file), the candidates
(comma-separated, default c3), the suites' seed (default 82; rule3.md's: 83).

    python docs/data/buildings/walls_finetune/table.py                 # rule.md: table.md
    python docs/data/buildings/walls_finetune/table.py runs3 c5 83     # rule3.md: table3.md
    python docs/data/buildings/walls_finetune/table.py runs4 c5 84     # rule4.md: table4.md (its goal tolerance)
"""
import json
import sys
from pathlib import Path

R = Path(__file__).with_name(sys.argv[1] if len(sys.argv) > 1 else "runs")
CANDIDATES = (sys.argv[2] if len(sys.argv) > 2 else "c3").split(",")
S = int(sys.argv[3]) if len(sys.argv) > 3 else 82
J = {82: (8301, 11, 7341), 83: (8302, 12, 7441), 84: (8303, 13, 7541)}[S]
SETS = [(f"open buildings (scenes.py seed {J[0]}, 60)", "open", "A"),
        (f"one wall (gen.py seed {J[1]}, 40)", "onewall", "A"),
        (f"corridor, seed {S} (200)", f"corridor-s{S}", "B"), (f"doorway, seed {S} (200)", f"doorway-s{S}", "B"),
        (f"corner, seed {S} (200)", f"corner-s{S}", "B"),
        (f"navground's corridor, seeds {J[2]}-{J[2] + 99}", "navground", "B")]
NETS = [("E (shipped)", "E")] + [(c, c) for c in CANDIDATES]


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
if len(CANDIDATES) == 1 and all((g, n) in sums for g in "AB" for _, n in NETS):
    c = CANDIDATES[0]
    (_, ea, eca, _, _), (_, ca, cca, _, _) = sums[("A", "E")], sums[("A", c)]
    (_, eb, ecb, eab, _), (_, cb, ccb, cab, _) = sums[("B", "E")], sums[("B", c)]
    rule = {"1. A: at least 10 more goals, no collision": ca >= ea + 10 and cca == 0,
            "2. B: collisions no more": ccb <= ecb, "2. B: collisions approaching no more": cab <= eab,
            "2. B: goals no fewer": cb >= eb}
    if S == 84:  # rule4.md: goals within E's own spread between two noise draws
        rule["3. B: goals at least E's less 10"] = rule.pop("2. B: goals no fewer") or cb >= eb - 10
    for k, v in rule.items():
        print(f"- {k}: {'holds' if v else 'FAILS'}")
    print("adopted" if all(rule.values()) else "rejected")
