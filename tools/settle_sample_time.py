"""Measure what the paper's cost does at different sample times and horizons.

This is the measurement behind the ``paper`` preset's T = 1.5 s (docs/model.md):
    python tools/settle_sample_time.py [--out docs/data/settle_sample_time.json]
It runs the three Fig. 7 scenarios and the stress scenarios with the paper's cost at
several (T, H) and prints outcome, clearance, tracking error, longest stop and the most
the robot moved backwards.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from casadi_gpc.config import preset
from casadi_gpc.planner.gpc import GPCController
from scenarios.metrics import episode_metrics
from scenarios.simulator import simulate
from scenarios import load_scenario

ROOT = Path(__file__).resolve().parents[1]
SCENARIOS = sorted((ROOT / "scenarios" / "paper").glob("*.toml")) + sorted((ROOT / "scenarios" / "stress").glob("*.toml"))
GRID = [("paper", 0.5, 6), ("paper", 1.0, 6), ("paper", 1.5, 6), ("paper", 0.5, 18), ("paper-dm", 1.5, 6),
        ("improved", 0.5, 12)]
# The paper's weights with lengths in decimetres, written in SI: squared lengths weigh 100x
# more, 1/dist^2 100x less (the clearance softening scales too).
DECIMETRES = dict(tracking_weight=100.0, lambda1=6300.0, lambda2=1000.0, xi_moving=0.03, xi_static=0.03)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--out", type=Path, default=None, help="rows as JSON")
    ap.add_argument("--markdown", type=Path, default=None, help="the table as Markdown")
    args = ap.parse_args()
    rows = []
    for name, T, H in GRID:
        cfg = preset(name.removesuffix("-dm")).with_overrides(sample_time_s=T, horizon=H)
        if name.endswith("-dm"):
            cfg = cfg.with_overrides(**DECIMETRES)
        for path in SCENARIOS:
            sc = load_scenario(path)
            log = simulate(sc, GPCController(cfg, sc.robot), "gpc")
            m = episode_metrics(log)
            st = np.asarray(log.states)
            v = 0.5 * (st[:, 3] + st[:, 4])
            backwards_s = float(np.sum(v < -0.02) * T)
            row = dict(preset=name, T=T, H=H, scenario=sc.name, outcome=m.outcome,
                       min_clearance_m=round(m.min_clearance_m, 3), tracking_rmse_m=round(m.tracking_rmse_m, 3),
                       longest_stop_s=m.longest_stop_s, backwards_s=backwards_s,
                       decision_median_ms=round(m.compute_median_s * 1e3, 2))
            rows.append(row)
            print(f"{name:8s} T={T:3.1f} H={H:2d} {sc.name:26s} {m.outcome:12s} clearance {m.min_clearance_m:6.3f} "
                  f"rmse {m.tracking_rmse_m:5.3f} stop {m.longest_stop_s:4.1f}s backwards {backwards_s:4.1f}s "
                  f"decision {m.compute_median_s * 1e3:6.2f} ms", flush=True)
    if args.markdown:
        lines = ["| preset | T (s) | H | scenario | outcome | min clearance (m) | tracking RMSE (m) | stop (s) | backwards (s) |",
                 "|---|---|---|---|---|---|---|---|---|"]
        lines += [f"| {r['preset']} | {r['T']} | {r['H']} | {r['scenario']} | {r['outcome']} | {r['min_clearance_m']:.2f} "
                  f"| {r['tracking_rmse_m']:.2f} | {r['longest_stop_s']:.1f} | {r['backwards_s']:.1f} |" for r in rows]
        args.markdown.write_text("\n".join(lines) + "\n")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
