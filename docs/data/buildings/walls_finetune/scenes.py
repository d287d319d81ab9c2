"""Open buildings for the walls network's fine-tuning and its judgement (docs/buildings.md, "The walls
network fine-tuned on open buildings"): scenes unlike the suites' corridors, where the shipped walls
network stops short of its goal (docs/buildings.md, "A wall on one side"). Three kinds, drawn in turn:

* ``wall``: one straight wall beside a straight path, 0.6 to 4 m to its left or right, tilted up to 5
  degrees, running 2 m behind the start to 2-6 m past the goal;
* ``room``: a closed rectangular room 3 to 6 m wide, the path along it 0 to a quarter of the width
  off its middle, the goal 0.6 to 2.5 m before the end wall;
* ``end``: one wall across the path 0.6 to 2.5 m past the goal, 4 to 12 m long, off-centre up to 2 m.

In about two of five scenes (``wall`` and ``end`` only) 1 to 3 ORCA walkers who do not see the robot
come the other way along the free side. The path is 4 to 10 m at 0.4 m/s, the time limit its time and
15 s. Each scene is a scenario file (the contract's format).

    python docs/data/buildings/walls_finetune/scenes.py OUT_DIR SEED COUNT
"""
import math
import random
import sys
from pathlib import Path

KINDS = ("wall", "room", "end")


def _walker(rng, length: float, y_lo: float, y_hi: float) -> str:
    y0, y1 = rng.uniform(y_lo, y_hi), rng.uniform(y_lo, y_hi)
    return f'''[[moving_obstacles]]
position = [{rng.uniform(0.5 * length, length + 3.0):.2f}, {y0:.2f}]
radius_m = {rng.uniform(0.22, 0.3):.2f}
behaviour = "orca"
goal = [-3.0, {y1:.2f}]
preferred_speed_mps = {rng.uniform(0.3, 0.6):.2f}
'''


def scene(rng: random.Random, kind: str, name: str) -> str:
    length = rng.uniform(4.0, 10.0)
    head = f'''name = "{name}"
duration_s = {math.ceil(length / 0.4) + 15}.0
[robot]
position = [0.0, 0.0]
heading_deg = 0.0
[reference]
position = [0.0, 0.0]
heading_deg = 0.0
speed_mps = 0.4
[[reference.segments]]
line_m = {length:.2f}
'''
    walkers = ""
    if kind == "wall":
        side, off, tilt = rng.choice([-1, 1]), rng.uniform(0.6, 4.0), math.radians(rng.uniform(-5, 5))
        x0, x1 = -2.0, length + rng.uniform(2.0, 6.0)
        y0, y1 = side * off + x0 * math.tan(tilt), side * off + x1 * math.tan(tilt)
        walls = f"[[walls]]\npoints = [[{x0:.2f}, {y0:.3f}], [{x1:.2f}, {y1:.3f}]]\n"
        lo, hi = (-2.5, off - 0.5) if side > 0 else (-(off - 0.5), 2.5)
        if rng.random() < 0.4:
            walkers = "".join(_walker(rng, length, lo, hi) for _ in range(rng.randint(1, 3)))
    elif kind == "room":
        width = rng.uniform(3.0, 6.0)
        yc = -rng.uniform(-0.25, 0.25) * width  # the room's middle, seen from the path
        xe = length + rng.uniform(0.6, 2.5)
        h = width / 2
        pts = [[-1.0, yc - h], [xe, yc - h], [xe, yc + h], [-1.0, yc + h], [-1.0, yc - h]]
        walls = "[[walls]]\npoints = [" + ", ".join(f"[{x:.2f}, {y:.3f}]" for x, y in pts) + "]\n"
    else:
        xe, half, yc = length + rng.uniform(0.6, 2.5), rng.uniform(2.0, 6.0), rng.uniform(-2.0, 2.0)
        walls = f"[[walls]]\npoints = [[{xe:.2f}, {yc - half:.3f}], [{xe:.2f}, {yc + half:.3f}]]\n"
        if rng.random() < 0.4:
            walkers = "".join(_walker(rng, length - 0.5, -2.5, 2.5) for _ in range(rng.randint(1, 3)))
    return head + walls + walkers


def main(out: Path, seed: int, count: int) -> None:
    out.mkdir(parents=True, exist_ok=True)
    rng = random.Random(seed)
    for k in range(count):
        kind = KINDS[k % len(KINDS)]
        name = f"{kind}-{seed}-{k:03d}"
        (out / f"{name}.toml").write_text(scene(rng, kind, name))


if __name__ == "__main__":
    main(Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]))
