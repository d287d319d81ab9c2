"""The rule's table (rule.md): both sides on every set (navground's files under two noise
draws), the totals, and the episode-by-episode sign test of the goals.
python table.py RUNS   (RUNS: run.sh's OUTDIR, or runs/ here; from the repository root)"""
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))
from scenarios.paired import outcome_changes, sign_test  # noqa: E402

runs = Path(sys.argv[1])
SETS = ["navground/run-0/EVAL", "navground/run-1/EVAL", "corridor", "doorway", "corner", "sq20", "ucy-replay",
        "ucy-reactive"]


def count(E):
    approaching = sum(1 for e in E if e.get("collision") and e["collision"]["robot_speed_towards_mps"] > 0.05
                      and e["collision"]["obstacle_age_s"] >= 1)
    return [sum(e["outcome"] == k for e in E) for k in ("reached_goal", "collided")] + [approaching] + \
        [sum(e["outcome"] == "timed_out" for e in E)]


print("| set | shipped | a cold start every other tick | goals gained / lost |")
print("|---|---|---|---|")
tot = {"shipped": [0] * 4, "option": [0] * 4}
gained = lost = 0
for s in SETS:
    E = {side: json.load(open(runs / side / f"{s}.json"))["episodes_detail"] for side in tot}
    assert [e["scenario"] for e in E["shipped"]] == [e["scenario"] for e in E["option"]], s
    c = {side: count(E[side]) for side in tot}
    g, l = outcome_changes(E["shipped"], E["option"])["reached_goal"]
    gained, lost = gained + g, lost + l
    for side in tot:
        tot[side] = [a + b for a, b in zip(tot[side], c[side])]
    a, b = c["shipped"], c["option"]
    print(f"| {s.replace('/EVAL', '')} | {a[0]} / {a[1]} ({a[2]}) / {a[3]} | {b[0]} / {b[1]} ({b[2]}) / {b[3]} | +{g} / -{l} |")
a, b = tot["shipped"], tot["option"]
print(f"| all | {a[0]} / {a[1]} ({a[2]}) / {a[3]} | {b[0]} / {b[1]} ({b[2]}) / {b[3]} | +{gained} / -{lost} |")
print(f"\ngoals episode by episode: {gained} gained, {lost} lost, exact two-sided sign test p = {sign_test(gained, lost):.3g}")
