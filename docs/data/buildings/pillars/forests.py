"""A look beyond the rule (not part of it): corridors 7.2 m wide holding many pillars, the
deployed network with and without the static discs in its walls network's scan
(``OnnxPolicy(statics_as_walls=...)``). Scene ``k``: a 14 m straight reference at 0.4 m/s
through the corridor's middle, ``N`` pillars of 0.2-0.35 m drawn 0.5-3 m either side of it
(``random.Random(100 + k)``, kept 0.8 m apart), two ORCA walkers blind to the robot crossing the
corridor, 80 s.

    python forests.py N COUNT     # e.g. 25 12
"""
import math
import random
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))

from casadi_gpc.config import preset  # noqa: E402
from gpcnav.commands.common import for_run  # noqa: E402
from gpcnav.controllers import ControllerSpec, make  # noqa: E402
from scenarios.loader import scenario_from_dict  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402


def forest(k: int, n: int) -> dict:
    rnd = random.Random(100 + k)
    placed = []
    while len(placed) < n:
        x, y, r = rnd.uniform(1.5, 13.5), rnd.choice([-1, 1]) * rnd.uniform(0.5, 3.0), rnd.uniform(0.2, 0.35)
        if all(math.hypot(x - a, y - b) > r + c + 0.8 for a, b, c in placed):
            placed.append((x, y, r))
    return {"name": f"forest_walls_{k}", "duration_s": 80.0,
            "robot": {"position": [0.0, 0.0], "heading_deg": 0.0},
            "reference": {"position": [0.0, 0.0], "heading_deg": 0.0, "speed_mps": 0.4, "segments": [{"line_m": 14.0}]},
            "static_obstacles": [{"position": [x, y], "radius_m": r} for x, y, r in placed],
            "moving_obstacles": [
                {"position": [7.0, -3.0], "radius_m": 0.3, "behaviour": "orca", "goal": [7.5, 3.0], "preferred_speed_mps": 0.4},
                {"position": [12.0, 3.0], "radius_m": 0.3, "behaviour": "orca", "goal": [4.0, -3.0],
                 "preferred_speed_mps": 0.45}],
            "walls": [{"points": [[-3.0, 3.6], [17.0, 3.6]]}, {"points": [[-3.0, -3.6], [17.0, -3.6]]}]}


n_pillars, count = int(sys.argv[1]), int(sys.argv[2])
res = {False: [], True: []}
for k in range(count):
    sc = scenario_from_dict(forest(k, n_pillars))
    cfg = for_run(preset("improved"), [sc])
    for on in (False, True):
        pol = make(ControllerSpec("nn"), cfg, sc.robot)
        pol.policy.statics_as_walls = on
        res[on].append(simulate(sc, pol, "nn").outcome)
    print(k, "off:", res[False][-1], " on:", res[True][-1], flush=True)
for on in (False, True):
    print("on" if on else "off", {o: res[on].count(o) for o in ("reached_goal", "collided", "timed_out")})
