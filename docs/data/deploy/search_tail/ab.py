"""The code before (BASE, a worktree) and after (HEAD) alternated, one process each
(:mod:`replay`, 3 passes a process, each decision's median over them), ROUNDS rounds of warm then
cold, and summarised: per run the median, p90, p99 and max of the failing decisions (the command
failed the quick screen: the check asked for the network's roll-out) and of all decisions, and
whether every decision's wheel speeds are the same to the bit in every run.

    python docs/data/deploy/search_tail/ab.py OBS.pkl BASE HEAD ROUNDS OUTDIR
"""
import json
import os
import subprocess
import sys

import numpy as np

obs, base, head, rounds, out = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5]
os.makedirs(out, exist_ok=True)
here = os.path.dirname(os.path.abspath(__file__))
runs = []
for r in range(rounds):
    for mode in ("warm", "cold"):
        for name, repo in ((("base", base), ("head", head)) if r % 2 == 0 else (("head", head), ("base", base))):
            path = os.path.join(out, f"{name}_{mode}_{r}.json")
            subprocess.run([sys.executable, os.path.join(here, "replay.py"), obs, mode, "3", path], check=True,
                           env={**os.environ, "PYTHONPATH": repo}, stdout=subprocess.DEVNULL)
            runs.append((name, mode, r, path))


def row(t):
    return f"{np.median(t):7.0f} {np.percentile(t, 90):7.0f} {np.percentile(t, 99):7.0f} {t.max():7.0f}"


wheels = None
print("run              | failing: median    p90     p99     max | all: median    p90     p99     max  (us)")
pooled = {}
for name, mode, r, path in runs:
    d = json.load(open(path))
    t, f = np.array(d["times_us"]), np.array(d["failing"])
    wheels = d["wheels"] if wheels is None else wheels
    assert d["wheels"] == wheels, f"{path}: other wheel speeds"
    pooled.setdefault((name, mode), []).append((t, f))
    print(f"{name} {mode} round {r}  | {row(t[f])} | {row(t)}")
print(f"every decision's wheel speeds the same to the bit in all {len(runs)} runs ({len(wheels)} decisions, "
      f"{int(f.sum())} failing)")
for mode in ("warm", "cold"):
    for name in ("base", "head"):
        t = np.concatenate([x for x, _ in pooled[(name, mode)]])
        f = np.concatenate([y for _, y in pooled[(name, mode)]])
        print(f"pooled {name} {mode} | {row(t[f])} | {row(t)}")
    b = [np.median(x[y]) for x, y in pooled[("base", mode)]]
    h = [np.median(x[y]) for x, y in pooled[("head", mode)]]
    print(f"  {mode}: the failing decisions' median, head over base, round by round: "
          + ", ".join(f"{x / y:.2f}" for x, y in zip(h, b)))
