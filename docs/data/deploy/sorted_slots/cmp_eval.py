import json, sys
a, b = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
ea = {e["scenario"]: e for e in a["episodes_detail"]}; eb = {e["scenario"]: e for e in b["episodes_detail"]}
keys = ("outcome", "steps", "interventions", "fallbacks", "min_clearance_m", "path_length_m")
diff = [n for n in ea if any(ea[n].get(k) != eb.get(n, {}).get(k) for k in keys)]
tally = lambda d: {o: sum(e["outcome"] == o for e in d["episodes_detail"]) for o in ("reached_goal", "collision", "timed_out")}
print(len(ea), len(eb), "episodes differing:", len(diff), diff[:5])
print("record", tally(a), a["compute_time_s"]["median"], a["compute_time_s"]["p99"], a["compute_time_s"]["max"])
print("now   ", tally(b), b["compute_time_s"]["median"], b["compute_time_s"]["p99"], b["compute_time_s"]["max"])
