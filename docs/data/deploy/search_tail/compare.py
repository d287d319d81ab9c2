"""Every episode of closedloop.sh's runs, before and after, compared: outcome, steps, interventions,
fallbacks, smallest clearance, tracking error, path length, time to goal and the danger measures
(the floats to the bit); the decision times are not compared."""
import glob
import json
import os
import sys

out = sys.argv[1]
KEYS = ("outcome", "steps", "interventions", "fallbacks", "min_clearance_m", "tracking_rmse_m", "path_length_m",
        "time_to_goal_s", "danger_steps", "danger_clearance_sum_m", "collision")
for base in sorted(glob.glob(os.path.join(out, "base-*.json"))):
    head = base.replace("base-", "head-")
    a, b = (json.load(open(p))["episodes_detail"] for p in (base, head))
    same = sum(all(x.get(k) == y.get(k) for k in KEYS) for x, y in zip(a, b))
    goals = sum(x["outcome"] == "reached_goal" for x in b)
    print(f"{os.path.basename(base)[5:-5]}: {same} of {len(a)} episodes the same (of {len(b)}); reached {goals}, "
          f"interventions {sum(x['interventions'] for x in b)}")
