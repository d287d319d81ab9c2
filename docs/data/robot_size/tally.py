"""The table of docs/model.md, "Robots of other sizes", from the COMPARE.json files here:
reached / collided (the robot approaching) / timed out, interventions of the check an episode,
the decision's median and p99 (ms), for each case, controller and robot radius.
``python docs/data/robot_size/tally.py``."""
import json
from pathlib import Path

here = Path(__file__).parent
rows = {}
for f in sorted(here.glob("*/COMPARE.json")):
    case, radius = f.parent.name.rsplit("-", 1)
    for c in json.loads(f.read_text())["controllers"]:
        n = c["episodes"]
        reached, collided, out = (round(c[k] * n) for k in ("success_rate", "collision_rate", "timeout_rate"))
        t = c["compute_time_s"]
        timing = f"{1e3 * t['median']:.2f} / {1e3 * t['p99']:.1f}" if t.get("median") is not None else "-"
        rows.setdefault((case, c["controller"]), {})[radius] = (
            f"{reached} / {collided} ({c['collided_robot_approaching']}) / {out}, "
            f"{c['interventions'] / n:.2f}, {timing}")
radii = sorted({r for v in rows.values() for r in v})
print("| case (40 episodes, seed 50) | controller | " + " | ".join(f"robot {r} m" for r in radii) + " |")
print("|---|---|" + "---|" * len(radii))
for (case, ctrl), v in rows.items():
    print(f"| {case} | {ctrl} | " + " | ".join(v.get(r, "") for r in radii) + " |")
