"""Forty scenes of one straight wall beside a straight path and no one about (docs/buildings.md, "A wall
on one side"): the wall 0.8 to 4 m to the left or the right of the path, tilted up to 5 degrees, the
path 4 to 10 m at 0.4 m/s, the time limit the path's time and 15 s.

    python docs/data/buildings/one_wall/gen.py OUT_DIR [SEED]     (SEED 7: the forty of the table)
    gpcnav evaluate OUT_DIR/*.toml --controller nn --workers 2 --out nn.json    # and --controller gpc
"""
import math
import random
import sys
from pathlib import Path

out = Path(sys.argv[1])
out.mkdir(parents=True, exist_ok=True)
rng = random.Random(int(sys.argv[2]) if len(sys.argv) > 2 else 7)
for k in range(40):
    side, off, length, tilt = rng.choice([-1, 1]), rng.uniform(0.8, 4.0), rng.uniform(4, 10), rng.uniform(-5, 5)
    y0 = side * off
    y1 = y0 + 14 * math.tan(math.radians(tilt))
    (out / f"sw{k:02d}.toml").write_text(f'''name = "sw{k:02d}"
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
[[walls]]
points = [[-2.0, {y0:.3f}], [12.0, {y1:.3f}]]
''')
