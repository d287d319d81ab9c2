"""The table of a rule run on the 1 058 cases of 2026-11-29 (trust_time/, cold_start_gap_rule/,
two_cold_starts/): the shipped GPC's runs of them against the option's, per set and in all
(reached / collided (robot approaching) / timed out, interventions); the shipped GPC run
again where the folder has such a run (the same outcome episode by episode?); the option's
decision times; and the back-to-back pairs of a folder's shipped/ and option/ runs that share
a name outside the sets (decision medians, p99, max).

    python rule_table.py FOLDER "the option's column title"   (from this folder)
"""
import json
import os
import sys

SETS = ["corridor", "doorway", "corner", "sq20", "ucy-replay", "ucy-reactive", "navground-corridor", "held-out-reactive"]
BASE = {s: f"passing/shipped/{s}.json" for s in SETS[:7]}
BASE["held-out-reactive"] = "reactive_entry/EVAL-gpc-held-out-78-quiet.json"


def load(path):
    return json.load(open(path))


def count(d):
    E = d["episodes_detail"]
    reached, collided, timed_out = (sum(e["outcome"] == k for e in E) for k in ("reached_goal", "collided", "timed_out"))
    approaching = sum(1 for e in E if e.get("collision") and e["collision"]["robot_speed_towards_mps"] > 0.05
                      and e["collision"]["obstacle_age_s"] >= 1)
    return reached, collided, approaching, timed_out, d["interventions"]


def times(d):
    t = d["compute_time_s"]
    return f"median {t['median'] * 1e3:.2f} ms, p99 {t['p99'] * 1e3:.1f} ms, max {t['max'] * 1e3:.1f} ms"


def main(folder, title):
    for s in SETS:
        again = os.path.join(folder, "shipped", f"{s}.json")
        if os.path.exists(again):
            a, b = load(again)["episodes_detail"], load(BASE[s])["episodes_detail"]
            same = sum(x["scenario"] == y["scenario"] and x["outcome"] == y["outcome"] and x["steps"] == y["steps"]
                       for x, y in zip(a, b))
            print(f"the shipped GPC run again on {s}: the same outcome in {same} of {len(b)} episodes\n")
    print(f"| set | shipped | {title} |")
    print("|---|---|---|")
    tot = [[0] * 5, [0] * 5]
    for s in SETS:
        base, opt = load(BASE[s]), load(os.path.join(folder, "option", f"{s}.json"))
        assert [e["scenario"] for e in base["episodes_detail"]] == [e["scenario"] for e in opt["episodes_detail"]], s
        a, b = count(base), count(opt)
        for t, c in zip(tot, (a, b)):
            for k in range(5):
                t[k] += c[k]
        print(f"| {s} | {a[0]} / {a[1]} ({a[2]}) / {a[3]}, {a[4]} interventions | {b[0]} / {b[1]} ({b[2]}) / {b[3]}, {b[4]} |")
    a, b = tot
    print(f"| all | {a[0]} / {a[1]} ({a[2]}) / {a[3]}, {a[4]} | {b[0]} / {b[1]} ({b[2]}) / {b[3]}, {b[4]} |\n")
    for s in SETS:
        print(f"{s}: the option's decisions (two workers): {times(load(os.path.join(folder, 'option', f'{s}.json')))}")
    for name in sorted(os.listdir(os.path.join(folder, "shipped"))):
        if name.endswith(".json") and os.path.exists(os.path.join(folder, "option", name)):
            for who in ("shipped", "option"):
                d = load(os.path.join(folder, who, name))
                print(f"{name}, back to back ({d.get('workers', '?')} workers): {who} {count(d)[0]} reached, {times(d)}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
