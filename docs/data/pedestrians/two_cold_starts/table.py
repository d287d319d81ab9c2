"""The rule's table (rule.md): the shipped GPC's runs against the option's, per set and in all, and the
decision times (two workers; and the one-worker pair of criterion 4).
python table.py   (from this folder)"""
import json
SETS = ["corridor", "doorway", "corner", "sq20", "ucy-replay", "ucy-reactive", "navground-corridor", "held-out-reactive"]
BASE = {s: f"../passing/shipped/{s}.json" for s in SETS[:7]}  # as in ../trust_time/
BASE["held-out-reactive"] = "../reactive_entry/EVAL-gpc-held-out-78-quiet.json"


def count(path):
    d = json.load(open(path))
    E = d["episodes_detail"]
    out = [sum(e["outcome"] == k for e in E) for k in ("reached_goal", "collided", "timed_out")]
    approaching = sum(1 for e in E if e.get("collision") and e["collision"]["robot_speed_towards_mps"] > 0.05
                      and e["collision"]["obstacle_age_s"] >= 1)
    return out[0], out[1], approaching, out[2], d["interventions"], {e["scenario"] for e in E}


print("| set | shipped | two cold starts a tick |")
print("|---|---|---|")
tot = [[0] * 5, [0] * 5]
for s in SETS:
    a, b = count(BASE[s]), count(f"option/{s}.json")
    assert a[5] == b[5], s
    for t, c in zip(tot, (a, b)):
        for k in range(5):
            t[k] += c[k]
    print(f"| {s} | {a[0]} / {a[1]} ({a[2]}) / {a[3]}, {a[4]} interventions | {b[0]} / {b[1]} ({b[2]}) / {b[3]}, {b[4]} |")
print(f"| all | {tot[0][0]} / {tot[0][1]} ({tot[0][2]}) / {tot[0][3]}, {tot[0][4]} | {tot[1][0]} / {tot[1][1]} ({tot[1][2]}) / {tot[1][3]}, {tot[1][4]} |")

print()
for s in SETS:
    t = json.load(open(f"option/{s}.json"))["compute_time_s"]
    print(f"{s}: option decision median {t['median'] * 1e3:.2f} ms, p99 {t['p99'] * 1e3:.1f} ms (two workers)")
for name, path in (("shipped", "shipped/held-out-reactive-1w.json"), ("option", "option/held-out-reactive-1w.json")):
    d = json.load(open(path))
    t = d["compute_time_s"]
    E = d["episodes_detail"]
    print(f"criterion 4, held-out reactive, one worker, back to back: {name} "
          f"{sum(e['outcome'] == 'reached_goal' for e in E)} reached, decision median {t['median'] * 1e3:.2f} ms, "
          f"p99 {t['p99'] * 1e3:.1f} ms, max {t['max'] * 1e3:.1f} ms")
