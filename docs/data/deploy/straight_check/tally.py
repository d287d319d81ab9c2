"""The table of rule.md's runs: reached / collided (robot approaching) / timed out and interventions an episode, the
shipped check (-0) against the option (-1), and the rule's three conditions."""
import json
import sys
from pathlib import Path

OUT = Path(sys.argv[1] if len(sys.argv) > 1 else Path(__file__).parent / "runs")
NAMES = ["cc5", "cc10", "sq5", "rm", "corridor", "doorway", "corner", "sq20", "ucy", "ucyr", "ng"]
ISSUE_SUITES = ["cc5", "cc10", "sq5", "rm"]
tot = {0: [0, 0, 0, 0], 1: [0, 0, 0, 0]}
ok2 = True
for name in NAMES:
    row = []
    for e in (0, 1):
        d = json.loads((OUT / f"{name}-{e}.json").read_text())
        n = d["episodes"]
        r, c, t = (round(d[k] * n) for k in ("success_rate", "collision_rate", "timeout_rate"))
        a = int(d.get("collided_robot_approaching", 0))
        for i, v in enumerate((r, c, t, a)):
            tot[e][i] += v
        row.append((r, c, t, a, d["interventions"] / n))
    (r0, c0, t0, a0, i0), (r1, c1, t1, a1, i1) = row
    if name in ISSUE_SUITES and ((c0 == 0 and c1 > 0) or r1 < r0 - 2):
        ok2 = False
    print(f"{name:9s} shipped {r0}/{c0}({a0})/{t0} int/ep {i0:.2f} | straight {r1}/{c1}({a1})/{t1} int/ep {i1:.2f}")
print("totals (reached, collided, timed out, approaching):", tot)
ok1 = tot[1][1] <= tot[0][1] and tot[1][3] <= tot[0][3]
ok3 = tot[1][0] >= tot[0][0]
print("rule: 1", ok1, "| 2", ok2, "| 3", ok3, "->", "adopt" if ok1 and ok2 and ok3 else "reject")
