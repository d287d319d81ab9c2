"""The deployed network (behind its planner-free check, as `gpcnav evaluate --controller nn` makes it) with and
without its walls network, on three rooms (the goal 0.8 to 2 m before the end wall, 3 to 6 m wide), the forty
one-wall scenes of gen.py (argv[1]: their folder) and the first 20 episodes of the three building suites, seed 2
(docs/buildings.md, "A wall on one side"). Without it, the crowd network answers and the walls are only the
check's.

    python docs/data/buildings/one_wall/without_walls_network.py OUT_DIR    # output: without_walls_network.txt
"""
import collections
import glob
import sys

from casadi_gpc.config import preset
from gpcnav.controllers import ControllerSpec, make
from scenarios import Suite
from scenarios.loader import load_scenario, scenario_from_dict
from scenarios.simulator import simulate

C = preset("improved")


def run(sc, walls_network: bool) -> str:
    ctl = make(ControllerSpec("nn"), C, sc.robot)
    if not walls_network:
        ctl.policy._walls = None
    return simulate(sc, ctl, "nn").outcome


def room(width: float, end_wall_x: float):
    h = width / 2
    return scenario_from_dict({
        "name": "room", "duration_s": 40.0, "robot": {"position": [0.0, 0.0], "heading_deg": 0.0},
        "reference": {"position": [0.0, 0.0], "heading_deg": 0.0, "speed_mps": 0.4, "segments": [{"line_m": 6.0}]},
        "walls": [{"points": [[-1.0, -h], [end_wall_x, -h], [end_wall_x, h], [-1.0, h], [-1.0, -h]]}]})


sets = [("rooms (3)", [room(4.0, 7.0), room(3.0, 6.8), room(6.0, 8.0)]),
        ("one wall (40)", [load_scenario(f) for f in sorted(glob.glob(sys.argv[1] + "/sw*.toml"))])]
sets += [(f"{s} seed 2 (20)", [Suite(s, 20, 2, 5).scenario(i) for i in range(20)]) for s in ("corridor", "doorway", "corner")]
for label, scenes in sets:
    for wn in (True, False):
        c = collections.Counter(run(sc, wn) for sc in scenes)
        print(f"{label:22s} {'with' if wn else 'without':7s} the walls network: "
              f"{c['reached_goal']} reached / {c['collided']} collided / {c['timed_out']} timed out")
