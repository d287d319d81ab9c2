"""The check's compiled clearances with ``math.hypot`` (as before 2026-11-29) and with the
inlined ``sqrt(x * x + y * y)`` (:func:`casadi_gpc.safety.distances._norm`), on the deployed
decisions of the bench's scene (circle-crossing, 10 ORCA walkers, seed 1, its first 10
episodes, recorded closed loop with the shipped code).

1. The kernel alone: every ``chord_clearances`` call of those decisions, recorded, then timed
   with each form (9 rounds, interleaved), and their answers compared.
2. The whole decision: the recorded observations replayed through fresh deployed controllers
   (``--controller nn``: the network behind the planner-free check), the kernel alternating
   round by round (8 rounds, one process), each decision's median over the rounds.

    python docs/data/deploy/clearance_norm/ab.py
"""
import inspect
import time

import numpy as np
from numba import njit

import casadi_gpc.safety.clearances as C
import casadi_gpc.safety.distances as D
from casadi_gpc.config import preset
from gpcnav.controllers import ControllerSpec, make
from scenarios import Suite
from scenarios.simulator import simulate


def hypot_form():
    """The kernel as it was: the same source with ``math.hypot`` for ``_norm``."""
    src = inspect.getsource(D.chord_clearances.py_func)
    src = src[src.index("def chord_clearances"):].replace("_norm(", "math.hypot(")
    scope = dict(D.__dict__)
    exec(src, scope)
    return njit(D.chord_clearances.signatures[0])(scope["chord_clearances"])


OLD, NEW = hypot_form(), D.chord_clearances
cfg = preset("improved")
calls, episodes = [], []


def recording(*a):
    calls.append(a)
    return NEW(*a)


C.chord_clearances = recording
for i in range(10):
    sc = Suite("circle-crossing", 200, 1, 10, "orca").scenario(i)
    pol = make(ControllerSpec("nn"), cfg, sc.robot)
    rec, decide = [], pol.policy.decide
    pol.policy.decide = lambda o, rec=rec, decide=decide: (rec.append(o), decide(o))[1]
    simulate(sc, pol, "nn")
    episodes.append((sc, rec))
C.chord_clearances = NEW

same = sum(all(np.array_equal(x, y) for x, y in zip(OLD(*a)[2:], NEW(*a)[2:])) for a in calls)
worst = max(max(float(np.max(np.abs(o[0] - n[0]))), abs(o[1] - n[1])) for o, n in ((OLD(*a), NEW(*a)) for a in calls))
times = {"hypot": [], "sqrt": []}
for _ in range(9):
    for name, fn in (("hypot", OLD), ("sqrt", NEW)):
        t0 = time.perf_counter()
        for a in calls:
            fn(*a)
        times[name].append(time.perf_counter() - t0)
print(f"kernel: {len(calls)} recorded calls; chords, obstacles and counts the same in {same}; "
      f"largest difference of a clearance {worst:.1e} m")
print(f"kernel: all calls, median of 9 rounds: hypot {np.median(times['hypot']) * 1e3:.2f} ms, "
      f"sqrt {np.median(times['sqrt']) * 1e3:.2f} ms, ratio {np.median(times['hypot']) / np.median(times['sqrt']):.2f}")

res = {"hypot": [], "sqrt": []}
for rnd in range(8):
    order = (("hypot", OLD), ("sqrt", NEW)) if rnd % 2 == 0 else (("sqrt", NEW), ("hypot", OLD))
    for name, fn in order:
        C.chord_clearances = fn
        tot, chk = [], []
        for sc, rec in episodes:
            s = make(ControllerSpec("nn"), cfg, sc.robot)
            for o in rec:
                t0 = time.perf_counter()
                d = s.decide(o)
                tot.append(time.perf_counter() - t0)
                chk.append(d.info["safety_time_s"])
        res[name].append((tot, chk))
C.chord_clearances = NEW
tot = {k: np.median(np.array([a for a, _ in v]), axis=0) * 1e3 for k, v in res.items()}
chk = {k: np.median(np.array([b for _, b in v]), axis=0) * 1e3 for k, v in res.items()}
heavy = chk["hypot"] > np.percentile(chk["hypot"], 95)
print(f"decisions: {len(tot['sqrt'])}, each timed as its median over the rounds")
for k in ("hypot", "sqrt"):
    print(f"  {k}: decision median {np.median(tot[k]):.3f} ms, p99 {np.percentile(tot[k], 99):.3f} ms, "
          f"max {tot[k].max():.3f} ms; the heaviest 5 % of checks {chk[k][heavy].mean():.3f} ms (mean)")
