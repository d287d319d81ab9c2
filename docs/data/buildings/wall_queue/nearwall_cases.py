"""Cases of a robot that starts against a wall (as one leaving a charging dock does): the
``corridor`` suite's episodes of a seed with the robot's start moved to 0.01-0.05 m from one of
the two walls (the side, the gap and a heading in [-180, 180) degrees drawn from
``numpy.random.default_rng([seed, i])``), its reference and walkers unchanged. An episode whose
walker starts within 0.9 m of the moved robot is left out and named. Written as scenario files.

    python nearwall_cases.py SEED COUNT OUT_DIR [--no-walkers]

``--no-walkers``: the same starts with the walkers taken out (nothing near the robot but the
walls: the situation the rules' probe scenes had, which the suite's walkers near the start do
not give).
"""
import math
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))

from casadi_gpc.robot import RobotState  # noqa: E402
from scenarios import Suite  # noqa: E402
from scenarios.loader import load_scenario  # noqa: E402
from scenarios.writer import scenario_document, to_toml  # noqa: E402

seed, count, out = int(sys.argv[1]), int(sys.argv[2]), Path(sys.argv[3])
alone = "--no-walkers" in sys.argv[4:]
out.mkdir(parents=True, exist_ok=True)
suite = Suite("corridor", count, seed, 5, "orca")
for i in range(count):
    sc = suite.scenario(i)
    rng = np.random.default_rng([seed, i])
    side, gap, heading = rng.choice([-1.0, 1.0]), rng.uniform(0.01, 0.05), rng.uniform(-math.pi, math.pi)
    y = side * (1.25 - sc.robot.radius_m - gap)
    if not alone and any(math.hypot(m.position_m[0], m.position_m[1] - y) < 0.9 for m in sc.moving):
        print(f"{sc.name}: a walker starts beside the moved robot, left out")
        continue
    moved = replace(sc, name=f"nearwall{'-alone' if alone else ''}-{sc.name}",
                    robot_start=RobotState(0.0, float(y), float(heading)), moving=() if alone else sc.moving)
    path = out / f"{moved.name}.toml"
    path.write_text(to_toml(scenario_document(moved)))
    load_scenario(path)  # refuses what the format refuses
print(len(list(out.glob("*.toml"))), "files in", out)
