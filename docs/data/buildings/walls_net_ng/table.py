"""A rule's table from its run folder: per set the shipped walls network and the candidate,
reached / collided (robot approaching) / timed out, goals gained and lost episode by episode, and
the rule's three conditions over the 700 episodes (``tools/rule_table.py``).

    python table.py runs > table.md      (rule.md: C on seed 27 and navground 6001-6100)
    python table.py runs2 > table2.md    (rule4.md: E on seed 28 and navground 6101-6200)
    python table.py runs3 > table3.md    (rule5.md: F on seed 29 and navground 6201-6300)
    python table.py runs4 > table4.md    (rule6.md: G on seed 30 and navground 6301-6400)
    python table.py runs5 > table5.md    (rule7.md: H on seed 31 and navground 6401-6500)
    python table.py runs6 > table6.md    (rule8.md: E's check with the margin near walls, seed 32, navground 6501-6600)
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[4] / "tools"))
from rule_table import compare, verdict  # noqa: E402

runs = Path(sys.argv[1])
# the folder: its suite seed, its first navground seed and the candidate's name
seed, ng, candidate = {"runs": (27, 6001, "C"), "runs2": (28, 6101, "E"), "runs3": (29, 6201, "F"),
                       "runs4": (30, 6301, "G"), "runs5": (31, 6401, "H"),
                       "runs6": (32, 6501, "E + margin")}[runs.name]
SETS = [f"corridor-s{seed}", f"doorway-s{seed}", f"corner-s{seed}", f"ng{ng}"]
tot = compare(runs, {"nn": SETS}, file=lambda side, c, name: f"{side}-{name}.json", median=False,
              extra=(f"interventions an episode ({candidate})",
                     lambda doc: f"{doc['interventions'] / doc['episodes']:.1f}"))["nn"]


def reached(side):
    return sum(sum(e["outcome"] == "reached_goal" for e in json.loads((runs / f"{side}-{n}.json").read_text())
                   ["episodes_detail"]) for n in SETS)


goals = (reached("shipped"), reached("change"))
verdict([
    (f"1. collisions: {tot['shipped'][0]} -> {tot['change'][0]}", tot["change"][0] <= tot["shipped"][0]),
    (f"2. with the robot approaching: {tot['shipped'][1]} -> {tot['change'][1]}", tot["change"][1] <= tot["shipped"][1]),
    (f"3. goals reached: {goals[0]} -> {goals[1]} (+{tot['gained']} / -{tot['lost']} episode by episode)",
     goals[1] > goals[0]),
])
