"""rule2.md's selection: each candidate's reached / collided (approaching) / timed out on rule.md's
cases (runs/), the fewest collisions then the most goals, and whether the chosen one meets
rule.md's three conditions against the shipped network.

    python choose.py runs > choose.md
"""
import json
import sys
from pathlib import Path

runs = Path(sys.argv[1])
SETS = ["corridor-s27", "doorway-s27", "corner-s27", "ng6001"]


def totals(side):
    r = c = a = 0
    cells = []
    for n in SETS:
        d = json.loads((runs / f"{side}-{n}.json").read_text())
        o = [e["outcome"] for e in d["episodes_detail"]]
        cells.append(f"{o.count('reached_goal')} / {o.count('collided')} ({d['collided_robot_approaching']}) / "
                     f"{o.count('timed_out')}")
        r, c, a = r + o.count("reached_goal"), c + o.count("collided"), a + d["collided_robot_approaching"]
    return r, c, a, cells


print("| network | " + " | ".join(SETS) + " | all: reached / collided (approaching) |")
print("|" + "---|" * (len(SETS) + 2))
rows = {}
for side, name in (("shipped", "shipped"), ("change", "C (seed 0)"), ("c-s1", "C-s1"), ("c-s2", "C-s2")):
    r, c, a, cells = rows[side] = totals(side)
    print(f"| {name} | " + " | ".join(cells) + f" | {r} / {c} ({a}) |")
best = min(("change", "c-s1", "c-s2"), key=lambda s: (rows[s][1], -rows[s][0]))
r, c, a, _ = rows[best]
R, C, A, _ = rows["shipped"]
ok = c <= C and a <= A and r > R
print(f"\nChosen: {best} ({r} reached, {c} collided, {a} approaching); against the shipped network "
      f"({R}, {C}, {A}) it {'meets' if ok else 'does not meet'} rule.md's three conditions"
      f"{': it goes to the confirmation' if ok else ': rejected, nothing more is run'}.")
