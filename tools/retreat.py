"""How much a robot drove back along its own reference, from RUN.json files (``gpcnav simulate
--out``): the share of samples it moved against the path's direction, the largest retreat
(how far it fell behind the furthest point it had reached) and the distance it drove
backwards, per episode and summarised by outcome (medians).

Progress is the arc length of the nearest point of the reference path (RUN.json's
``reference_path``), the path extended straight before its start and past its end, so a robot
that backs off behind its start is measured too. A sample counts as moving back when its
progress falls faster than 0.05 m/s (the contract's mark of the robot's own motion).

    gpcnav simulate scenario.toml --controller gpc --out runs/scenario.json   # for each file
    python tools/retreat.py runs/*.json --out RETREAT.json
    python tools/retreat.py --suite corridor --count 20 --seed 1              # simulated here
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

BACK_MPS = 0.05
"""Progress falling faster than this is driving back."""


def progress_m(path_xy: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Arc length along the polyline ``path_xy`` (P, 2) of the nearest point to each of ``xy``
    (N, 2), the first and last segments extended without end."""
    a, b = path_xy[:-1], path_xy[1:]
    seg = b - a
    length = np.hypot(seg[:, 0], seg[:, 1])
    keep = length > 0
    a, seg, length = a[keep], seg[keep], length[keep]
    start = np.concatenate([[0.0], np.cumsum(length)[:-1]])
    rel = xy[:, None, :] - a[None, :, :]
    t = np.einsum("nsk,sk->ns", rel, seg) / length ** 2
    lo = np.zeros(len(length))
    hi = np.ones(len(length))
    lo[0], hi[-1] = -np.inf, np.inf
    t = np.clip(t, lo, hi)
    near = a[None] + t[..., None] * seg[None]
    d = np.hypot(*(xy[:, None, :] - near).transpose(2, 0, 1))
    k = np.argmin(d, axis=1)
    rows = np.arange(len(xy))
    return start[k] + t[rows, k] * length[k]


def episode(run: dict) -> dict:
    """The retreat figures of one RUN.json."""
    tr = run["trajectory"]
    xy = np.column_stack([tr["x"], tr["y"]])
    s = progress_m(np.asarray(run["reference_path"], dtype=float), xy)
    rate = np.diff(s) / float(run["sample_time_s"])
    behind = np.maximum.accumulate(s) - s
    return {"scenario": run["scenario"], "outcome": run["outcome"],
            "share_moving_back": float(np.mean(rate < -BACK_MPS)) if len(rate) else 0.0,
            "largest_retreat_m": float(behind.max()),
            "driven_back_m": float(-np.sum(np.diff(s)[rate < -BACK_MPS])),
            "path_length_m": float(run["path_length_m"])}


def suite_runs(name: str, count: int, seed: int, movers: int, controller: str, preset_name: str) -> list[dict]:
    """The RUN documents of a seeded suite's first ``count`` episodes, as ``gpcnav simulate``
    writes them (the controller behind its default check layer)."""
    from casadi_gpc.config import preset
    from gpcnav.commands.common import for_run
    from gpcnav.commands.simulate import run_one
    from gpcnav.controllers import ControllerSpec, check
    from scenarios.suites import Suite
    suite, config = Suite(name, count=count, seed=seed, movers=movers), preset(preset_name)
    scenarios = [suite.scenario(i) for i in range(count)]
    check(ControllerSpec(controller), config, scenarios[0].robot)
    return [run_one(sc, controller, for_run(config, [sc])) for sc in scenarios]


def summary(rows: list[dict]) -> dict:
    out = {}
    for outcome in sorted({r["outcome"] for r in rows}):
        r = [x for x in rows if x["outcome"] == outcome]
        out[outcome] = {"episodes": len(r), **{f"{k}_median": float(np.median([x[k] for x in r]))
                                               for k in ("share_moving_back", "largest_retreat_m", "driven_back_m",
                                                         "path_length_m")},
                        "largest_retreat_m_max": float(max(x["largest_retreat_m"] for x in r))}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="*", help="RUN.json files")
    ap.add_argument("--suite", help="simulate this seeded suite's episodes instead")
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--movers", type=int, default=5)
    ap.add_argument("--controller", default="gpc")
    ap.add_argument("--preset", default="improved")
    ap.add_argument("--out", help="write the episodes and the summary here (JSON)")
    args = ap.parse_args(argv)
    if bool(args.runs) == bool(args.suite):
        print("retreat: give RUN.json files or --suite, one of the two", file=sys.stderr)
        return 2
    rows = []
    if args.suite:
        from gpcnav.errors import UsageError
        try:
            runs = suite_runs(args.suite, args.count, args.seed, args.movers, args.controller, args.preset)
        except (ValueError, UsageError) as exc:  # an unknown suite, controller or preset, a count below 1
            print(f"retreat: {exc}", file=sys.stderr)
            return 2
        rows = [episode(r) for r in runs]
    for f in args.runs:
        try:
            rows.append(episode(json.loads(Path(f).read_text())))
        except (OSError, ValueError, KeyError) as exc:
            print(f"retreat: {f}: not a RUN.json with a trajectory ({exc})", file=sys.stderr)
            return 2
    summ = summary(rows)
    for outcome, s in summ.items():
        print(f"{outcome:12s} {s['episodes']:4d} episodes: moving back {100 * s['share_moving_back_median']:.0f} % "
              f"of the samples, largest retreat {s['largest_retreat_m_median']:.1f} m (max "
              f"{s['largest_retreat_m_max']:.1f}), driven back {s['driven_back_m_median']:.1f} m, path "
              f"{s['path_length_m_median']:.1f} m (medians)")
    if args.out:
        Path(args.out).write_text(json.dumps({"summary": summ, "episodes": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
