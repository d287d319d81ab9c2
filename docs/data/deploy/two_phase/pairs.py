"""The two-phase way out against the shipped check, suite by suite: reached / collided
(robot approaching) / timed out, interventions an episode, the two-phase counters, decision
median / p99. Usage: python pairs.py DIR (base-NAME.json beside two-NAME.json)."""
import json
import sys
from pathlib import Path

d = Path(sys.argv[1])
tot = {"base": [0, 0, 0, 0], "two": [0, 0, 0, 0]}
print("| suite | check | reached / collided (approaching) / timed out | interventions an episode | two-phase searched / taken | decision median / p99 ms |")
print("|---|---|---|---|---|---|")
for b in sorted(d.glob("base-*.json")):
    name = b.stem[5:]
    t = d / f"two-{name}.json"
    if not t.exists():
        continue
    for label, f in (("shipped", b), ("two-phase", t)):
        e = json.load(open(f))
        det = e["episodes_detail"]
        r = sum(x["outcome"] == "reached_goal" for x in det)
        c = sum(x["outcome"] == "collided" for x in det)
        o = sum(x["outcome"] == "timed_out" for x in det)
        a = e["collided_robot_approaching"]
        ev = e.get("events", {})
        ct = e["compute_time_s"]
        key = "base" if label == "shipped" else "two"
        for k, v in enumerate((r, c, a, o)):
            tot[key][k] += v
        print(f"| {name} | {label} | {r} / {c} ({a}) / {o} | {e['interventions'] / len(det):.2f} | "
              f"{ev.get('shield_two_phase_searched', 0)} / {ev.get('shield_two_phase_taken', 0)} | "
              f"{ct['median'] * 1e3:.2f} / {ct['p99'] * 1e3:.1f} |")
for key, (r, c, a, o) in tot.items():
    print(f"| all | {'shipped' if key == 'base' else 'two-phase'} | {r} / {c} ({a}) / {o} | | | |")
