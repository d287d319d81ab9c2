"""The tables of run.sh: reached / collided (robot approaching) / timed out over all 452 cases and
over the first 40 (the `--count 40 --seed 1` cases), each controller, both modes, and what changed
in crowds_zara02. python docs/data/pedestrians/zara02_people/tally.py [DIR]"""
import collections
import json
import sys
from pathlib import Path

D = Path(sys.argv[1] if len(sys.argv) > 1 else "docs/data/pedestrians/zara02_people")


def cell(eps, approaching=None):
    t = collections.Counter(e["outcome"] for e in eps)
    a = "" if approaching is None else f" ({approaching})"
    return f"{t['reached_goal']} / {t['collided']}{a} / {t['timed_out']}"


def approaching(eps):
    """scenarios.metrics' rule, from the episodes' collisions."""
    from scenarios.metrics import robot_approaching
    return sum(robot_approaching(e.get("collision")) for e in eps)


for mode in ("replay", "reactive"):
    print(f"\n{mode}: all 452 | the first 40 | crowds_zara02 (243) | decision ms median / p99 / max")
    for c in ("stand", "blind", "gpc", "nn"):
        if not (D / f"{c}-{mode}-452.json").exists():
            continue
        d = json.load(open(D / f"{c}-{mode}-452.json"))
        eps = d["episodes_detail"]
        z2 = [e for e in eps if e["scenario"].startswith("crowds_zara02")]
        t = d["compute_time_s"]
        print(f"| {c} | {cell(eps, d['collided_robot_approaching'])} | {cell(eps[:40], approaching(eps[:40]))} | "
              f"{cell(z2, approaching(z2))} | {t['median'] * 1e3:.2f} / {t['p99'] * 1e3:.1f} / {t['max'] * 1e3:.0f} |")
    f = D / f"compare-peers-40-{'replay' if mode == 'replay' else 'orca'}.json"
    if f.exists():
        doc = json.load(open(f))
        for row in doc.get("controllers", doc.get("results", [])):
            name = row.get("controller") or row.get("name")
            eps = row.get("episodes_detail", [])
            print(f"| {name} | | {cell(eps, row.get('collided_robot_approaching'))} | | |")
