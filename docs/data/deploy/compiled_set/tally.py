"""The rule's tally (rule.md): each set's reached / collided (approaching) / timed out, both sides, and the sums."""
import json, sys
from pathlib import Path
d = Path(sys.argv[1])
tot = {}
for name in ("ucyr47", "ng7101"):
    line = []
    for side in ("ort", "compiled"):
        doc = json.loads((d / f"{name}-{side}.json").read_text())
        ep = doc["episodes_detail"]
        r = sum(e["outcome"] == "reached_goal" for e in ep); c = sum(e["outcome"] == "collided" for e in ep)
        a = doc.get("collided_robot_approaching", 0)
        t = tot.setdefault(side, [0, 0, 0, 0]); t[0] += r; t[1] += c; t[2] += a; t[3] += len(ep) - r - c
        line.append(f"{side} {r} / {c} ({a}) / {len(ep) - r - c}")
    print(f"{name:8s} " + "   ".join(line))
print("sum      " + "   ".join(f"{s} {t[0]} / {t[1]} ({t[2]}) / {t[3]}" for s, t in tot.items()))
o, n = tot["ort"], tot["compiled"]
print("adopted" if n[1] <= o[1] and n[2] <= o[2] and n[0] >= o[0] else "not adopted: the compiled pass stays an option")
