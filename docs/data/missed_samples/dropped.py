"""Dropped frames in closed loop: at a fraction of the samples (seeded) the controller is not asked
and the robot holds its last command, as a robot whose perception or decision loop missed a frame
would; the controller's next observation comes two or more samples after its last. The code of
REPO (argv[1]; run with PYTHONPATH=REPO), CONTROLLER (argv[2]: nn or gpc, as gpcnav makes them),
circle-crossing among 10 ORCA walkers that do not see the robot, COUNT episodes from SEED
(argv[3], argv[4]), frames dropped with probability P (argv[5]). Prints the outcomes and the
filters' counts, and writes one JSON line per episode to argv[6]."""
import json
import sys

import numpy as np

sys.path.insert(0, sys.argv[1])
from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.types import ControlDecision  # noqa: E402
from gpcnav.controllers import ControllerSpec, make  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402
from scenarios.suites import Suite  # noqa: E402

repo, name, count, seed, p, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]), \
    sys.argv[6]


class Dropping:
    """``inner`` not asked at a fraction ``p`` of the samples (never twice in a row, never the first):
    its last command held."""

    def __init__(self, inner, p, seed):
        self.inner, self.p, self.seed = inner, p, seed
        self.sample_time_s = inner.sample_time_s

    def reset(self):
        self.inner.reset()
        self.rng, self.last, self.dropped = np.random.default_rng(self.seed), None, 0

    def decide(self, obs):
        if self.last is not None and not self.last.reason.startswith("dropped") and self.rng.random() < self.p:
            self.dropped += 1
            self.last = ControlDecision(self.last.v_right_mps, self.last.v_left_mps, False, "dropped frame: held")
            return self.last
        self.last = self.inner.decide(obs)
        return self.last

    @property
    def counters(self):
        return {**self.inner.counters, "dropped_frames": self.dropped}


cfg = preset("improved")
suite = Suite("circle-crossing", count, seed, 10, "orca")
tally, sums = {}, {}
with open(out, "w") as f:
    for i in range(count):
        sc = suite.scenario(i)
        log = simulate(sc, Dropping(make(ControllerSpec(name), cfg, sc.robot), p, 1000 + i), name)
        tally[log.outcome] = tally.get(log.outcome, 0) + 1
        ev = {k: log.events.get(k, 0) for k in ("dropped_frames", "missed_samples", "outliers", "ghosts",
                                                  "manoeuvres", "interventions")}
        for k, v in ev.items():
            sums[k] = sums.get(k, 0) + v
        f.write(json.dumps({"episode": i, "outcome": log.outcome, "steps": len(log.t),
                            "min_clearance_m": log.min_clearance_m, **ev}) + "\n")
print(repo, name, f"seed {seed} x{count} p={p}", dict(sorted(tally.items())), sums)
