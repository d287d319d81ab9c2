"""How far the walls network is from its own mirror image at each of its decisions (the largest wheel's
difference between its answer and the mirrored answer to the mirrored features, m/s): in three rooms, the forty
one-wall scenes of gen.py (in /tmp/sw: `python gen.py /tmp/sw`) and the first 10 episodes of the three building
suites, seed 2 (docs/buildings.md, "A wall on one side"). Output: mirror_gap.txt.

    python docs/data/buildings/one_wall/mirror_gap.py
"""
import sys, glob, numpy as np
from nn_export.runtime import side_networks
from nn_export.runtime.features import mirror_features
from casadi_gpc.config import preset
from gpcnav.controllers import ControllerSpec, make
from scenarios import Suite
from scenarios.loader import load_scenario, scenario_from_dict
from scenarios.simulator import simulate
stats = []
orig = side_networks.CrowdNetwork.answer
def answer(self, values):
    vr, vl = orig(self, values)
    if self.role == "walls":
        M = mirror_features(self.layout, np.asarray(values, dtype=float)).astype(np.float32)[None]
        m = self.session.run(None, {self.session.get_inputs()[0].name: M})[0][0]
        stats.append(max(abs(vr - m[1]), abs(vl - m[0])))
    return vr, vl
side_networks.CrowdNetwork.answer = answer
C = preset("improved")
def room(width, end_wall_x):
    h = width / 2
    return scenario_from_dict({"name": "room", "duration_s": 40.0, "robot": {"position": [0.0, 0.0], "heading_deg": 0.0},
        "reference": {"position": [0.0, 0.0], "heading_deg": 0.0, "speed_mps": 0.4, "segments": [{"line_m": 6.0}]},
        "walls": [{"points": [[-1.0, -h], [end_wall_x, -h], [end_wall_x, h], [-1.0, h], [-1.0, -h]]}]})
sets = [("rooms", [room(4.0, 7.0), room(3.0, 6.8), room(6.0, 8.0)]),
        ("one wall", [load_scenario(f) for f in sorted(glob.glob("/tmp/sw/sw*.toml"))])]
sets += [(s, [Suite(s, 10, 2, 5).scenario(i) for i in range(10)]) for s in ("corridor", "doorway", "corner")]
for label, scs in sets:
    stats.clear()
    for sc in scs:
        simulate(sc, make(ControllerSpec("nn"), C, sc.robot), "nn")
    a = np.array(stats)
    print(f"{label:10s} decisions {len(a):5d}  mirror gap median {np.median(a):.3f}  p90 {np.percentile(a, 90):.3f}  p99 {np.percentile(a, 99):.3f}  share > 0.05: {np.mean(a > 0.05):.2f}")
