"""The whole deployable decision with the check's clearances before (BASE's kernel) and after (this
tree's), alternated round by round in one process so that both meet the same load: the recorded
observations (record.py's pickle, argv[1]) replayed through fresh ``--controller nn`` controllers, 8
rounds, ``warm`` (back to back) and ``cold`` (32 MB of other memory summed between decisions);
each decision's median over its rounds, then the median, p90, p99 and max of the failing decisions
(the command failed the quick screen) and of all, and every decision's wheel speeds compared.

    PYTHONPATH=. python docs/data/deploy/search_tail/decisions.py OBS.pkl BASE
"""
import pickle
import sys
import time

import numpy as np
from numba import njit

import casadi_gpc.safety.clearances as C
import casadi_gpc.safety.distances as D
from casadi_gpc.config import preset
from gpcnav.controllers import ControllerSpec, make
from scenarios import Suite

obs_path, base = sys.argv[1], sys.argv[2]
NEW = D.chord_clearances
src = open(f"{base}/casadi_gpc/safety/distances.py").read()
src = src[src.index("def chord_clearances"):src.index("    return cmin, now, chord, which, kept")] + \
    "    return cmin, now, chord, which, kept, contact, fixed, drives, rdrives\n"
scope = dict(D.__dict__)
exec(src, scope)
OLD = njit(NEW.signatures[0])(scope["chord_clearances"])
with open(obs_path, "rb") as f:
    recorded = pickle.load(f)
episodes, SUITE = recorded["episodes"], recorded["suite"]
cfg = preset("improved")
robots = {i: Suite(*SUITE).scenario(i).robot for i, _ in episodes}
big = np.ones(4_000_000)


def run(kernel, cold):
    C.chord_clearances = kernel
    times, failing, wheels = [], [], []
    for i, rec in episodes:
        pol = make(ControllerSpec("nn"), cfg, robots[i])
        counters = pol.filter.counters
        for o, _ in rec:
            if cold:
                big.sum()
            before = counters["rollouts"]
            t0 = time.perf_counter()
            d = pol.decide(o)
            times.append(time.perf_counter() - t0)
            failing.append(counters["rollouts"] > before)
            wheels.append((d.v_right_mps.hex(), d.v_left_mps.hex()))
    return np.array(times) * 1e6, np.array(failing), wheels


def row(t):
    return f"{np.median(t):6.0f} {np.percentile(t, 90):6.0f} {np.percentile(t, 99):6.0f} {t.max():6.0f}"


for mode in ("warm", "cold"):
    got = {"before": [], "after": []}
    for r in range(8):
        for label, kernel in ((("before", OLD), ("after", NEW)) if r % 2 == 0 else (("after", NEW), ("before", OLD))):
            got[label].append(run(kernel, mode == "cold"))
    wheels = got["before"][0][2]
    fl = got["before"][0][1]
    assert all(w == wheels for _, _, w in got["before"] + got["after"]), "other wheel speeds"
    assert all(np.array_equal(f, fl) for _, f, _ in got["before"] + got["after"])
    print(f"{mode}: {len(wheels)} decisions, {fl.sum()} failing, every wheel speed the same to the bit in all 16 runs")
    print("            failing: median    p90    p99    max | all: median    p90    p99    max (us)")
    med = {}
    for label in ("before", "after"):
        t = np.median(np.array([x for x, _, _ in got[label]]), axis=0)
        med[label] = t
        print(f"  {label:7s}          {row(t[fl])} |      {row(t)}")
    ratio = [np.median(a[0][fl]) / np.median(b[0][fl]) for a, b in zip(got["after"], got["before"])]
    summed = med["after"][fl].sum() / med["before"][fl].sum()
    print("  the failing decisions' median, after over before, round by round: "
          + ", ".join(f"{x:.2f}" for x in ratio) + f"; their summed time {summed:.2f}x")
