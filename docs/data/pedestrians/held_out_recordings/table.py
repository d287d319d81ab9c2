"""The held-out recordings' table (docs/pedestrians.md, "Recordings never used before"): per
controller and recording, reached / collided (appeared on it < 1 s, robot approaching) / timed
out, from COMPARE.json files. Usage: python table.py COMPARE.json [COMPARE.json ...]"""
import json
import sys
from collections import defaultdict

APPEARED_S = 1.0  # as tools/forecast_bound.py: in the scene for less than this
rows = defaultdict(lambda: defaultdict(lambda: dict(reached=0, collided=0, appeared=0, approaching=0, timed_out=0)))
for path in sys.argv[1:]:
    for ctl in json.load(open(path))["controllers"]:
        for e in ctl["episodes_detail"]:
            rec = e["scenario"].split("-")[0]
            for key in (rec, "all"):
                r = rows[ctl["controller"]][key]
                r["reached" if e["outcome"] == "reached_goal" else e["outcome"]] += 1
                c = e.get("collision") or {}
                if c:
                    appeared = c.get("obstacle_age_s", 0.0) < APPEARED_S
                    r["appeared"] += appeared
                    r["approaching"] += (not appeared) and c.get("robot_speed_towards_mps", 0.0) > 0.05
recs = sorted({k for v in rows.values() for k in v if k != "all"}) + ["all"]
print("| controller | " + " | ".join(recs) + " |")
print("|---|" + "---|" * len(recs))
for name, by in rows.items():
    cells = [f"{by[k]['reached']} / {by[k]['collided']} ({by[k]['appeared']}, {by[k]['approaching']}) / {by[k]['timed_out']}"
             for k in recs]
    print(f"| {name} | " + " | ".join(cells) + " |")
