"""The decision's time against the size of the map (docs/buildings.md, "Maps of any size"): a 3 m corridor of
two long walls with 0 to 5 000 small closed squares (4 segments each) scattered up to 50 m off it, three
people walking at the robot, an 8 m path at 0.4 m/s; one episode each of the network as deployed and of
the GPC, each behind its check (`gpcnav simulate`'s controllers), and their decision times.

    PYTHONPATH=REPO python docs/data/buildings/map_size/bench.py [gpc,nn]
"""
import random
import sys

from casadi_gpc.config import preset
from gpcnav.commands.simulate import run_one
from scenarios.loader import scenario_from_dict

C = preset("improved")


def scene(n_boxes: int):
    rng = random.Random(3)
    walls = [{"points": [[-5.0, s], [25.0, s]]} for s in (-1.5, 1.5)]
    for _ in range(n_boxes):
        cx, cy = rng.uniform(-50, 50), rng.choice([-1, 1]) * rng.uniform(3, 50)
        walls.append({"points": [[cx, cy], [cx + 0.3, cy], [cx + 0.3, cy + 0.3], [cx, cy + 0.3], [cx, cy]]})
    return scenario_from_dict({
        "name": "map", "duration_s": 40.0, "robot": {"position": [0.0, 0.0], "heading_deg": 0.0},
        "reference": {"position": [0.0, 0.0], "heading_deg": 0.0, "speed_mps": 0.4, "segments": [{"line_m": 10.0}]},
        "walls": walls,
        "moving_obstacles": [{"position": [8.0 + 3 * i, 0.6 * (-1) ** i], "heading_deg": 180.0, "speed_mps": 0.3,
                              "radius_m": 0.3} for i in range(3)]})


for n in (0, 100, 1000, 5000):
    sc = scene(n)
    for c in (sys.argv[1] if len(sys.argv) > 1 else "nn,gpc").split(","):
        d = run_one(sc, c, C)
        ct = d["compute_time_s"]
        print(f"{2 + 4 * n:6d} segments {c:3s} {d['outcome']:12s} decision median {ct['median'] * 1e3:6.2f} ms  "
              f"p95 {ct['p95'] * 1e3:6.2f}  max {ct['max'] * 1e3:6.1f}", flush=True)
