"""rule.md's tally: reached / collided / timed out (robot approaching) per set and summed, B against T,
from the runs' EVAL.json (usage: tally.py RUNS_FOLDER [BEFORE AFTER], the forms' names: B T, or NB NT
for nn_rule.md)."""
import json
import sys
from pathlib import Path

runs = Path(sys.argv[1] if len(sys.argv) > 1 else "out/rt/runs")
FORMS = tuple(sys.argv[2:4]) if len(sys.argv) > 3 else ("B", "T")
SETS = ["ucy", "ucyr", "sq30", "corner", "sq20", "corridor", "doorway", "ng"]


def counts(path):
    d = json.loads(path.read_text())
    eps = d["episodes_detail"]
    out = {k: sum(e["outcome"] == k for e in eps) for k in ("reached_goal", "collided", "timed_out")}
    out["approaching"] = d["collided_robot_approaching"]
    out["n"] = len(eps)
    ct = d["compute_time_s"]
    out["median_ms"], out["p99_ms"] = ct["median"] * 1e3, ct["p99"] * 1e3
    return out


total = {f: dict(reached_goal=0, collided=0, timed_out=0, approaching=0) for f in FORMS}
B, T = FORMS
print(f"| set | {B}: reached / collided (approaching) / timed out | {T} | decision median / p99, {B} / {T} (ms) |")
print("|---|---|---|---|")
for name in SETS:
    got = {f: runs / f"{f}-{name}.json" for f in FORMS}
    if not all(p.exists() for p in got.values()):
        print(f"| {name} | (not both run) | | |")
        continue
    c = {f: counts(p) for f, p in got.items()}
    for f in FORMS:
        for k in total[f]:
            total[f][k] += c[f][k]
    cell = lambda x: f"{x['reached_goal']} / {x['collided']} ({x['approaching']}) / {x['timed_out']}"  # noqa: E731
    print(f"| {name} ({c[B]['n']}) | {cell(c[B])} | {cell(c[T])} | "
          f"{c[B]['median_ms']:.2f} / {c[B]['p99_ms']:.1f}, {c[T]['median_ms']:.2f} / {c[T]['p99_ms']:.1f} |")
b, t = total[B], total[T]
print(f"| **sum** | {b['reached_goal']} / {b['collided']} ({b['approaching']}) / {b['timed_out']} | "
      f"{t['reached_goal']} / {t['collided']} ({t['approaching']}) / {t['timed_out']} | |")
passes = t["approaching"] < b["approaching"] and t["collided"] <= b["collided"] and t["reached_goal"] >= b["reached_goal"]
print(f"\nrule: fewer approaching {t['approaching']} < {b['approaching']}, no more collisions {t['collided']} <= "
      f"{b['collided']}, no fewer goals {t['reached_goal']} >= {b['reached_goal']}: {'PASSES' if passes else 'FAILS'}")
