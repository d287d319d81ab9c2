"""The rule's table (rule.md) from a run folder: per set and side reached / collided (robot
approaching) / timed out, the decisions the walls network passed over, goals gained and lost
episode by episode; the rule's three conditions (``tools/rule_table.py``).

    python table.py RUNS > table.md
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[4] / "tools"))
from rule_table import compare, p_lost, verdict  # noqa: E402

SETS = ["ng", "corridor", "doorway", "corner", "corridor-12", "doorway-12", "corner-12"]
tot = compare(Path(sys.argv[1]), {"nn": SETS}, first="set (the network behind its planner-free check)",
              file=lambda side, c, name: f"{side}-{name}.json", label=lambda c, name: name, median=False,
              extra=("decisions passed over", lambda doc: str(doc["events"].get("walls_network_passed_over", 0))))["nn"]
p = p_lost(tot["gained"], tot["lost"])
verdict([
    (f"1. the network's collisions {tot['shipped'][0]} -> {tot['change'][0]}", tot["change"][0] <= tot["shipped"][0]),
    (f"2. with the robot approaching {tot['shipped'][1]} -> {tot['change'][1]}", tot["change"][1] <= tot["shipped"][1]),
    (f"3. goals +{tot['gained']} / -{tot['lost']}, one-sided sign test p = {p:.3f}", p >= 0.1),
])
