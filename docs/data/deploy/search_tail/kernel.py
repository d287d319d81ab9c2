"""The check's compiled clearances before (the kernel of BASE, a worktree: every chord of every
obstacle its bound keeps) and after (this tree: blocks and chords that cannot change an answer left
out), on the calls the deployed decision makes: the recorded observations (record.py's pickle,
argv[1]) replayed through fresh ``--controller nn`` controllers, every ``chord_clearances`` call kept
with whether its decision's command failed the quick screen. Then, in one process: the answers
compared to the bit, the work counted (chords measured, blocks bounded, per sequence; instrumented
copies of the two kernels' source), and the two timed alternately over 15 rounds (medians; the
failing decisions' calls, the two phases' 38-sequence calls, and all).

    PYTHONPATH=. python docs/data/deploy/search_tail/kernel.py OBS.pkl BASE
"""
import inspect
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
old_src = open(f"{base}/casadi_gpc/safety/distances.py").read()
old_src = old_src[old_src.index("def chord_clearances"):old_src.index("    return cmin, now, chord, which, kept")] + \
    "    return cmin, now, chord, which, kept, contact, fixed, drives, rdrives\n"
new_src = inspect.getsource(NEW.py_func)
new_src = new_src[new_src.index("def chord_clearances"):]


def compiled(src, counting=False):
    scope = dict(D.__dict__)
    exec(src, scope)
    return njit(scope["chord_clearances"]) if counting else njit(NEW.signatures[0])(scope["chord_clearances"])


OLD = compiled(old_src)


def counted(src, marks):
    """The kernel with a counter array first: ``marks`` (line to find, counter) each add one where found."""
    src = src.replace("def chord_clearances(p,", "def chord_clearances(counts, p,")
    for line, k in marks:
        assert line in src, line
        indent = line[:len(line) - len(line.lstrip())]
        src = src.replace(line, f"{indent}counts[{k}] += 1\n{line}", 1)
    return compiled(src, True)


OLD_COUNT = counted(old_src, [("            computed[j] = True\n", 0)])  # x N chords
NEW_COUNT = counted(new_src, [("                            s = (rr.real * ur + rr.imag * ui)", 0),
                              ("                    u = pcen[k] - qcen[j, k]\n", 1)])

calls, failing_now = [], [False]


def recording(*a):
    calls.append((failing_now[0], tuple(x.copy() if isinstance(x, np.ndarray) else x for x in a)))
    return NEW(*a)


with open(obs_path, "rb") as f:
    recorded = pickle.load(f)
episodes, SUITE = recorded["episodes"], recorded["suite"]
cfg = preset("improved")
C.chord_clearances = recording
for i, rec in episodes:
    pol = make(ControllerSpec("nn"), cfg, Suite(*SUITE).scenario(i).robot)
    for o, _ in rec:
        before = pol.filter.counters["rollouts"]
        n = len(calls)
        pol.decide(o)
        if pol.filter.counters["rollouts"] > before:  # a failing decision: its calls marked
            calls[n:] = [(True, a) for _, a in calls[n:]]
C.chord_clearances = NEW


def same(x, y):
    (c1, n1, *i1), (c2, n2, *i2) = x, y
    return (np.array_equal(c1.view(np.int64), c2.view(np.int64)) and float(n1).hex() == float(n2).hex()
            and all(np.array_equal(a, b) for a, b in zip(i1, i2)))


sets = {"failing decisions' calls": [a for f, a in calls if f],
        "their 38-sequence calls (two phases)": [a for f, a in calls if f and a[0].shape[0] == 38],
        "all calls": [a for _, a in calls]}
print(f"{len(calls)} calls recorded, {len(sets[next(iter(sets))])} of them in failing decisions; answers the same "
      f"to the bit in {sum(same(OLD(*a), NEW(*a)) for _, a in calls)}")
for name, group in sets.items():
    if not group:
        continue
    rows = sum(a[0].shape[0] for a in group)
    N = group[0][0].shape[1] - 1
    oc, nc = np.zeros(1, np.int64), np.zeros(2, np.int64)
    for a in group:
        OLD_COUNT(oc, *a)
        NEW_COUNT(nc, *a)
    times = {"before": [], "after": []}
    for r in range(15):
        for label, fn in ((("before", OLD), ("after", NEW)) if r % 2 == 0 else (("after", NEW), ("before", OLD))):
            t0 = time.perf_counter()
            for a in group:
                fn(*a)
            times[label].append(time.perf_counter() - t0)
    b, h = np.median(times["before"]) / len(group) * 1e6, np.median(times["after"]) / len(group) * 1e6
    print(f"{name}: {len(group)} calls, {rows / len(group):.1f} sequences a call; chords measured a sequence "
          f"{oc[0] * N / rows:.1f} -> {nc[0] / rows:.1f} (and {nc[1] / rows:.1f} blocks bounded); "
          f"{b:.1f} -> {h:.1f} us a call, {h / b:.2f}x")
