"""The rule's table (rule.md) from a run folder: per set and side reached / collided (robot
approaching) / timed out and the decision median; goals gained and lost episode by episode;
the rule's four conditions (``tools/rule_table.py``).

    python table.py RUNS > table.md
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[4] / "tools"))
from rule_table import compare, p_lost, verdict  # noqa: E402

SETS = ["ucy-replay", "ucy-orca", "s001-replay", "s001-reactive", "corridor", "doorway", "corner", "sq20", "cc10", "ng"]
tot = compare(Path(sys.argv[1]), {"gpc": SETS, "nn": SETS})
G, N = tot["gpc"], tot["nn"]
pg, pn = p_lost(G["gained"], G["lost"]), p_lost(N["gained"], N["lost"])
worst = max(G["slower"], key=lambda x: x[1]) if G["slower"] else ("", 1.0)
col = (G["shipped"][0] + N["shipped"][0], G["change"][0] + N["change"][0])
app = (G["shipped"][1] + N["shipped"][1], G["change"][1] + N["change"][1])
verdict([
    (f"1. collisions, the GPC's and the network's: {col[0]} -> {col[1]}", col[1] <= col[0]),
    (f"2. with the robot approaching: {app[0]} -> {app[1]}", app[1] <= app[0]),
    (f"3. goals: the GPC +{G['gained']} / -{G['lost']} (p = {pg:.3f}), the network +{N['gained']} / -{N['lost']} "
     f"(p = {pn:.3f}), one-sided sign tests", pg >= 0.1 and pn >= 0.1),
    (f"4. the GPC's slowest set against shipped: {worst[0]} x{worst[1]:.3f}", worst[1] <= 1.10),
])
