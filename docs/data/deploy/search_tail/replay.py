"""Replay recorded observations (record.py's pickle, argv[1]) through fresh deployable controllers
(``--controller nn``: the network behind the planner-free check), one per episode, and time each
decision; the code is whatever ``PYTHONPATH`` holds. argv[2]: ``warm`` (decisions back to back) or
``cold`` (32 MB of other memory summed between decisions, as the simulator's work pushes the
decision's code and data out of the caches). argv[3]: passes over the 10 episodes. argv[4]: a JSON
file to write the per-decision times (us, each decision's median over the passes), the failing
flags (the command failed the quick screen: the check asked for the network's roll-out) and the
wheel speeds as ``float.hex``.

    PYTHONPATH=REPO python docs/data/deploy/search_tail/replay.py /tmp/obs.pkl cold 3 out.json
"""
import gc
import json
import pickle
import sys
import time

import numpy as np

import casadi_gpc
from casadi_gpc.config import preset
from gpcnav.controllers import ControllerSpec, make
from scenarios import Suite

path, mode, passes, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
with open(path, "rb") as f:
    recorded = pickle.load(f)
episodes, SUITE = recorded["episodes"], recorded["suite"]
cfg = preset("improved")
big = np.ones(4_000_000)
robots = {i: Suite(*SUITE).scenario(i).robot for i, _ in episodes}
times, failing, wheels = [], [], []
for p in range(passes):
    t_pass, f_pass, w_pass = [], [], []
    for i, rec in episodes:
        pol = make(ControllerSpec("nn"), cfg, robots[i])
        counters = pol.filter.counters
        for o, _ in rec:
            if mode == "cold":
                big.sum()
            before = counters["rollouts"]
            t0 = time.perf_counter()
            d = pol.decide(o)
            t_pass.append(time.perf_counter() - t0)
            f_pass.append(counters["rollouts"] > before)
            w_pass.append((d.v_right_mps.hex(), d.v_left_mps.hex()))
    times.append(t_pass)
    if p == 0:
        failing, wheels = f_pass, w_pass
    assert f_pass == failing and w_pass == wheels, "a pass decided otherwise"
t = np.median(np.array(times), axis=0) * 1e6
fl = np.array(failing)
recorded = [(w[0].hex(), w[1].hex()) for _, rec in episodes for _, w in rec]
same = sum(a == b for a, b in zip(wheels, recorded))
with open(out, "w") as f:
    json.dump({"code": casadi_gpc.__file__, "mode": mode, "passes": passes, "times_us": t.tolist(),
               "failing": failing, "wheels": wheels}, f)


def stats(x):
    return (f"median {np.median(x):7.1f} p90 {np.percentile(x, 90):7.1f} p99 {np.percentile(x, 99):7.1f} "
            f"max {x.max():7.1f} us")


print(f"{casadi_gpc.__file__} {mode} x{passes}: {len(t)} decisions ({same} as recorded), {fl.sum()} failing")
print(f"  all     {stats(t)}")
print(f"  failing {stats(t[fl])}")
print(f"  passing {stats(t[~fl])}")
