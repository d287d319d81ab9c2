"""The rule's table (rule.md) from a run folder: per set and side reached / collided (robot
approaching) / timed out and the decision median; goals gained and lost episode by episode;
the rule's five conditions (``tools/rule_table.py``).

    python table.py seed61 > table.md
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[4] / "tools"))
from rule_table import compare, p_lost, verdict  # noqa: E402

tot = compare(Path(sys.argv[1]), {"gpc": ["corridor", "doorway", "corner", "sq20", "cc10", "ucy-replay", "ucy-orca", "ng"],
                                  "nn": ["corridor", "doorway", "corner", "cc10", "ucy-orca"]})
G, N = tot["gpc"], tot["nn"]
p = p_lost(G["gained"], G["lost"])
worst = max(G["slower"], key=lambda x: x[1]) if G["slower"] else ("", 1.0)
verdict([
    (f"1. the GPC's collisions {G['shipped'][0]} -> {G['change'][0]}", G["change"][0] <= G["shipped"][0]),
    (f"2. with the robot approaching {G['shipped'][1]} -> {G['change'][1]}", G["change"][1] <= G["shipped"][1]),
    (f"3. goals +{G['gained']} / -{G['lost']}, one-sided sign test p = {p:.3f}", p >= 0.1),
    (f"4. the network's collisions {N['shipped'][0]} -> {N['change'][0]}", N["change"][0] <= N["shipped"][0]),
    (f"5. the GPC's slowest set against shipped: {worst[0]} x{worst[1]:.3f}", worst[1] <= 1.10),
])
