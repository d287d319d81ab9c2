"""Record the observations of the bench's crowd scene (circle-crossing, 10 ORCA walkers, seed 1, its
first 10 episodes; or argv[2:]: suite, movers, seed, episodes) as the deployable decision
(``--controller nn``) meets them closed loop, and the wheel speeds it answered, into a pickle
(argv[1]), with the suite's arguments.

    PYTHONPATH=REPO python docs/data/deploy/search_tail/record.py /tmp/obs.pkl [SUITE MOVERS SEED EPISODES]
"""
import pickle
import sys

from casadi_gpc.config import preset
from gpcnav.controllers import ControllerSpec, make
from scenarios import Suite
from scenarios.simulator import simulate

SUITE = (sys.argv[2], 200, int(sys.argv[4]), int(sys.argv[3]), "orca") if len(sys.argv) > 2 else \
    ("circle-crossing", 200, 1, 10, "orca")
cfg = preset("improved")
episodes = []
for i in range(int(sys.argv[5]) if len(sys.argv) > 5 else 10):
    sc = Suite(*SUITE).scenario(i)
    pol = make(ControllerSpec("nn"), cfg, sc.robot)
    rec, decide = [], pol.decide
    pol.decide = lambda o, rec=rec, decide=decide: (lambda d: (rec.append((o, (d.v_right_mps, d.v_left_mps))), d)[1])(
        decide(o))
    simulate(sc, pol, "nn")
    episodes.append((i, rec))
with open(sys.argv[1], "wb") as f:
    pickle.dump({"suite": SUITE, "episodes": episodes}, f)
print(sum(len(r) for _, r in episodes), "decisions recorded")
