"""The tables of record after the filter's change, beside those before: reached / collided
(robot approaching) / timed out per run of this folder, and, where the run before is in the
repository, how many episodes changed outcome.

    python tally.py
"""
import json
from pathlib import Path

HERE = Path(__file__).parent
B = HERE.parents[2]
BEFORE = {  # the runs of record before the change, where kept
    "gpc-corridor": B / "buildings/wall_queue/seed1/gpc-s1-corridor.json",
    "gpc-doorway": B / "buildings/wall_queue/seed1/gpc-s1-doorway.json",
    "gpc-corner": B / "buildings/wall_queue/seed1/gpc-s1-corner.json",
    "gpc-ng": B / "buildings/wall_queue/seed1/gpc-s1-ng.json",
    "gpc-ucy-orca-452": (B / "pedestrians/reactive_entry/COMPARE-all-452.json", "gpc"),
    "gpc-ucy-replay-452": (B / "pedestrians/reactive_entry/COMPARE-all-452-replay.json", "gpc"),
    "nn-ucy-orca-452": B / "deploy/straight_check/seed1/ucyr-452.json",
    "nn-ucy-replay-452": B / "deploy/straight_check/seed1/ucy-452.json",
}


def load(b):
    """An EVAL document, or one controller's entry of a COMPARE document."""
    if isinstance(b, tuple):
        doc = json.loads(b[0].read_text())
        return next(c for c in doc["controllers"] if c["controller"] == b[1])
    return json.loads(b.read_text())


def cell(doc):
    out = [x["outcome"] for x in doc["episodes_detail"]]
    return (f"{out.count('reached_goal')} / {out.count('collided')} ({doc['collided_robot_approaching']}) / "
            f"{out.count('timed_out')}")


print("| run | after | before | episodes that changed outcome |")
print("|---|---|---|---|")
for f in sorted([*HERE.glob("gpc-*.json"), *HERE.glob("nn-*.json")]):
    doc = json.loads(f.read_text())
    b = BEFORE.get(f.stem)
    if b is not None and (b[0] if isinstance(b, tuple) else b).is_file():
        old = load(b)
        o = {x["scenario"]: x["outcome"] for x in old["episodes_detail"]}
        n = sum(o.get(x["scenario"]) != x["outcome"] for x in doc["episodes_detail"])
        print(f"| {f.stem} | {cell(doc)} | {cell(old)} | {n} |")
    else:
        print(f"| {f.stem} | {cell(doc)} | | |")
