"""Who gives way, seen from the robot: can a person's reaction to the robot be told from
the positions a sensor gives, before planning with it? An offline study, nothing shipped.

For every mover and every sample at which it is in conflict with the robot (straight-line
closest approach within CONFLICT_S seconds and nearer than CONFLICT_M between centres, from
the relative position and the velocities over the previous sample), the change in that
miss distance that the person's own change of velocity makes by the next sample, the
robot's velocity held at the old one: a person who gives way to the robot widens it, one
who does not see the robot changes it only for others. Per track, the mean over its
conflict samples. The shipped GPC drives (``gpcnav``'s registry, ``improved``); positions
are the simulator's true ones at the 0.5 s samples (RUN.json's), so the study asks whether
the reaction is there to be seen, not how well a filter would see it.

Usage: python study.py [COUNT]   (writes study.json and prints the table)
"""
from __future__ import annotations

import glob
import json
import sys
from multiprocessing import Pool
from pathlib import Path

import numpy as np

CONFLICT_S = 4.0
CONFLICT_M = 1.0
HERE = Path(__file__).resolve().parent


def _sets(count: int):
    root = HERE.parents[3]
    ng = sorted(glob.glob(str(root / "out" / "ng-corridor" / "*.toml")))[:count]
    return [("navground Corridor (see the robot)", "file", ng),
            ("UCY reactive, ORCA (see the robot)", "ucy-orca", list(range(count))),
            ("corridor suite (blind ORCA)", "corridor", list(range(count))),
            ("UCY replayed (recorded people)", "ucy-replay", list(range(count))),
            ("square-crossing 20 (blind ORCA)", "sq20", list(range(count)))]


def _scenario(kind, item):
    from scenarios import load_scenario
    from scenarios.suites import Suite
    if kind == "file":
        return load_scenario(item)
    if kind == "ucy-orca":
        return Suite("ucy", 40, 1, 5, "orca").scenario(item)
    if kind == "ucy-replay":
        return Suite("ucy", 40, 1, 5, "replay").scenario(item)
    if kind == "corridor":
        return Suite("corridor", 200, 1, 5, "orca").scenario(item)
    return Suite("square-crossing", 200, 1, 20, "orca").scenario(item)


def _run(args):
    kind, item = args
    from casadi_gpc.config import preset
    from gpcnav.commands.common import for_run
    from gpcnav.commands.simulate import run_one
    sc = _scenario(kind, item)
    doc = run_one(sc, "gpc", for_run(preset("improved"), [sc]))
    return sc.name, scores(doc)


def scores(doc) -> list[tuple[float, int, float]]:
    """(mean change of the miss distance by the person's own manoeuvre, conflict samples, the
    smallest miss distance of those samples) per mover with at least one conflict sample."""
    tr = doc["trajectory"]
    T = doc["sample_time_s"]
    r = np.stack([tr["x"], tr["y"]], axis=1)
    n = len(r)
    out = []
    for ob in doc["obstacles"]:
        if ob.get("kind", "moving") != "moving":
            continue
        o = np.array([[np.nan if v is None else v for v in ob["x"]], [np.nan if v is None else v for v in ob["y"]]]).T
        deltas, misses = [], []
        for k in range(1, n - 1):
            if np.isnan(o[k - 1:k + 2]).any():
                continue
            vo, vr = (o[k] - o[k - 1]) / T, (r[k] - r[k - 1]) / T
            p, v = o[k] - r[k], vo - vr
            vv = float(v @ v)
            if vv < 1e-6:
                continue
            tau = -float(p @ v) / vv
            miss = float(np.hypot(*(p + v * tau)))
            if not (0.0 < tau < CONFLICT_S and miss < CONFLICT_M):
                continue
            vo2 = (o[k + 1] - o[k]) / T                  # the person's new velocity
            v2 = vo2 - vr                                 # the robot's held at the old one
            vv2 = float(v2 @ v2)
            tau2 = max(-float(p @ v2) / vv2, 0.0) if vv2 > 1e-6 else 0.0
            miss2 = float(np.hypot(*(p + v2 * tau2)))
            deltas.append(miss2 - miss)
            misses.append(miss)
        if deltas:
            out.append((float(np.mean(deltas)), len(deltas), float(min(misses))))
    return out


def main(argv=None) -> int:
    count = int((argv or sys.argv[1:] or ["20"])[0])
    sets = _sets(count)
    result = {}
    with Pool(2) as pool:
        for label, kind, items in sets:
            runs = pool.map(_run, [(kind, i) for i in items])
            per_track = [s for _, tracks in runs for s in tracks]
            result[label] = {"episodes": len(runs), "tracks": per_track}
    json.dump(result, open(HERE / "study.json", "w"), indent=1)
    print("| set | tracks in conflict | mean change per track: p10 / median / p90 (m) | share widening by more than 0.1 m "
          "| share whose straight line ever ran within contact (0.6 m) |")
    print("|---|---|---|---|---|")
    for label, r in result.items():
        m = np.array([t[0] for t in r["tracks"]])
        if not len(m):
            print(f"| {label} | 0 | | | |")
            continue
        p10, p50, p90 = np.percentile(m, [10, 50, 90])
        contact = np.array([t[2] for t in r["tracks"]]) < 0.6
        print(f"| {label} | {len(m)} | {p10:+.3f} / {p50:+.3f} / {p90:+.3f} | {np.mean(m > 0.1):.2f} | {contact.mean():.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
