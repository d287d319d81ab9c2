"""The rule's table (rule.md) from a run folder: per set and side reached / collided (robot
approaching) / timed out and the decision median; goals gained and lost episode by episode;
the rule's four conditions.

    python table.py RUNS > table.md
"""
import json
import sys
from pathlib import Path

from scipy.stats import binomtest

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))
from scenarios.paired import outcome_changes  # noqa: E402

d = Path(sys.argv[1])
SETS = {c: ["ucy-replay", "ucy-orca", "s001-replay", "s001-reactive", "corridor", "doorway", "corner", "sq20", "cc10",
            "ng"] for c in ("gpc", "nn")}
print("| controller, set | shipped: reached / collided (approaching) / timed out, decision median | the change | goals gained / lost |")
print("|---|---|---|---|")
tot = {c: {"shipped": [0, 0], "change": [0, 0], "gained": 0, "lost": 0, "slower": []} for c in SETS}
for c, sets in SETS.items():
    for name in sets:
        cells, eps = [], {}
        for side in ("shipped", "change"):
            f = d / f"{side}-{c}-{name}.json"
            if not f.is_file():
                cells.append("not run")
                continue
            doc = json.loads(f.read_text())
            e = doc["episodes_detail"]
            out = [x["outcome"] for x in e]
            med = doc["compute_time_s"]["median"] * 1e3
            cells.append(f"{out.count('reached_goal')} / {out.count('collided')} ({doc['collided_robot_approaching']}) / "
                         f"{out.count('timed_out')}, {med:.2f} ms")
            eps[side] = (e, med)
            tot[c][side][0] += out.count("collided")
            tot[c][side][1] += doc["collided_robot_approaching"]
        if len(eps) == 2:
            g, l = outcome_changes(eps["shipped"][0], eps["change"][0])["reached_goal"]
            tot[c]["gained"] += g
            tot[c]["lost"] += l
            tot[c]["slower"].append((name, eps["change"][1] / eps["shipped"][1]))
            gl = f"+{g} / -{l}"
        else:
            gl = ""
        print(f"| {c}, {name} | {cells[0]} | {cells[1]} | {gl} |")


def p_lost(g: int, l: int) -> float:
    """One-sided exact sign test: P(at least l of n = g + l changes are losses | fair coin)."""
    return float(binomtest(l, g + l, 0.5, alternative="greater").pvalue) if g + l else 1.0


G, N = tot["gpc"], tot["nn"]
pg, pn = p_lost(G["gained"], G["lost"]), p_lost(N["gained"], N["lost"])
worst = max(G["slower"], key=lambda x: x[1]) if G["slower"] else ("", 1.0)
col = (G["shipped"][0] + N["shipped"][0], G["change"][0] + N["change"][0])
app = (G["shipped"][1] + N["shipped"][1], G["change"][1] + N["change"][1])
conds = [
    (f"1. collisions, the GPC's and the network's: {col[0]} -> {col[1]}", col[1] <= col[0]),
    (f"2. with the robot approaching: {app[0]} -> {app[1]}", app[1] <= app[0]),
    (f"3. goals: the GPC +{G['gained']} / -{G['lost']} (p = {pg:.3f}), the network +{N['gained']} / -{N['lost']} "
     f"(p = {pn:.3f}), one-sided sign tests", pg >= 0.1 and pn >= 0.1),
    (f"4. the GPC's slowest set against shipped: {worst[0]} x{worst[1]:.3f}", worst[1] <= 1.10),
]
print()
for text, ok in conds:
    print(f"- {text}: {'holds' if ok else 'FAILS'}")
print(f"\n{'Adopted' if all(ok for _, ok in conds) else 'Rejected'} by the rule.")
