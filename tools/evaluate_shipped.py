"""Measure the shipped networks against the GPC: the issue-5 figures, in one run.

    python tools/evaluate_shipped.py [--workers 2] [--multi-model M.onnx] [--out docs]

For each preset (`paper`, `improved`), with the model shipped for it and its own number of
passes (metadata ``decision_passes``):

* the paper's three Fig. 7 situations: the GPC, the network as ``gpcnav simulate
  --controller nn`` runs it (safety filter with the GPC on standby) and the bare network;
  outcome, clearance, fallbacks, and the deviation of the network's path from the GPC's,
  as curves (scenarios.metrics.path_deviation_m) and at the same sample instants;
* the random suite (200 episodes, seed 1): GPC, network behind the filter, bare network;
* the encounters suite (the Fig. 7 family, 100 episodes, seed 1): the same path deviations
  per episode, bare network;
* with ``--multi-model``: the random-multi suite (200 episodes, seed 1), GPC against that
  model (its own preset), filtered and bare.

Writes ``OUT/shipped_models.md``, ``OUT/data/shipped_models.json`` and
``OUT/fig7_shipped.png`` (GPC and network paths, both presets). Not installed: a
repository tool (it needs the planner, onnxruntime and matplotlib).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from casadi_gpc.config import PRESETS  # noqa: E402
from casadi_gpc.io import save_figure, write_json, write_text  # noqa: E402
from scenarios.metrics import path_deviation_m, same_instant_deviation_m  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402
from gpcnav.controllers import make_controller  # noqa: E402
from gpcnav.commands.evaluate import evaluate  # noqa: E402
from nn_export.runtime.policy import OnnxPolicy, shipped_model_path  # noqa: E402
from scenarios import paper_scenarios, random_suite  # noqa: E402


def _rates(metrics) -> dict:
    n = len(metrics)
    out = {o: sum(1 for m in metrics if m.outcome == o) / n for o in ("reached_goal", "collided", "timed_out")}
    out["episodes"] = n
    out["fallbacks"] = int(sum(m.fallbacks for m in metrics))
    return out


def suite_rows(suite, count, seed, preset, model, workers) -> dict:
    config = PRESETS[preset]
    scs = random_suite(suite, count, seed)
    rows = {}
    for name, kind, safety in (("gpc", "gpc", None), ("nn+filter", "nn", "gpc"), ("nn bare", "nn", "off")):
        t0 = time.perf_counter()
        metrics, times, _ = evaluate(scs, kind, config, model if kind == "nn" else None, workers, desc=name,
                                     shield=safety)
        rows[name] = _rates(metrics) | {"decision_median_s": float(np.median(times)),
                                        "wall_s": time.perf_counter() - t0}
        print(f"{suite} {preset} {name}: {rows[name]}", flush=True)
    return rows


def xy(log) -> np.ndarray:
    return np.asarray(log.states)[:, :2]


def fig7_rows(preset, model) -> tuple[list, dict]:
    config = PRESETS[preset]
    rows, paths = [], {}
    for sc in paper_scenarios():
        g = simulate(sc, make_controller("gpc", config, sc.robot), "gpc")
        paths[(sc.name, "gpc")] = (xy(g), np.asarray(g.obstacle_xy))
        rows.append({"preset": preset, "scenario": sc.name, "controller": "gpc", "outcome": g.outcome,
                     "min_clearance_m": float(g.min_clearance_m), "fallbacks": int(g.fallbacks)})
        for name, safety in (("nn+filter", "gpc"), ("nn bare", "off")):
            ctrl = make_controller("nn", config, sc.robot, model, safety)
            n = simulate(sc, ctrl, "nn")
            paths[(sc.name, name)] = (xy(n), None)
            rows.append({"preset": preset, "scenario": sc.name, "controller": name, "outcome": n.outcome,
                         "min_clearance_m": float(n.min_clearance_m), "fallbacks": int(n.fallbacks),
                         "path_deviation_m": path_deviation_m(xy(n), xy(g)),
                         "same_instant_deviation_m": same_instant_deviation_m(xy(n), xy(g), n.t, g.t),
                         "passes": 2 if getattr(ctrl, "policy", ctrl).two_pass else 1})  # behind a Shield or bare
    return rows, paths


def encounter_rows(preset, model, count, seed) -> dict:
    config = PRESETS[preset]
    dev, devt, outs = [], [], []
    for sc in random_suite("encounters", count, seed):
        g = simulate(sc, make_controller("gpc", config, sc.robot), "gpc")
        n = simulate(sc, make_controller("nn", config, sc.robot, model, "off"), "nn")
        dev.append(path_deviation_m(xy(n), xy(g)))
        devt.append(same_instant_deviation_m(xy(n), xy(g), n.t, g.t))
        outs.append((g.outcome, n.outcome))
    dev, devt = np.asarray(dev), np.asarray(devt)
    return {"episodes": count, "seed": seed,
            "gpc_reached": sum(o[0] == "reached_goal" for o in outs) / count,
            "nn_reached": sum(o[1] == "reached_goal" for o in outs) / count,
            "nn_collided": sum(o[1] == "collided" for o in outs) / count,
            "path_deviation_median_m": float(np.median(dev)), "path_deviation_p90_m": float(np.quantile(dev, 0.9)),
            "within_0_25_m": float(np.mean(dev <= 0.25)),
            "same_instant_median_m": float(np.median(devt)), "same_instant_within_0_25_m": float(np.mean(devt <= 0.25))}


def figure(all_paths, out: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    scs = paper_scenarios()
    fig, axes = plt.subplots(3, 2, figsize=(13, 8.5))
    for j, preset in enumerate(("paper", "improved")):
        for i, sc in enumerate(scs):
            ax = axes[i, j]
            g, ob = all_paths[preset][(sc.name, "gpc")]
            n, _ = all_paths[preset][(sc.name, "nn+filter")]
            ax.plot(sc.reference.polyline(0.1)[:, 0], sc.reference.polyline(0.1)[:, 1], color="0.75", lw=1,
                    label="reference")
            ax.plot(ob[:, :, 0], ob[:, :, 1], ".", color="tab:red", ms=2)
            ax.plot(g[:, 0], g[:, 1], "k.-", lw=1.2, ms=4, label="GPC")
            ax.plot(n[:, 0], n[:, 1], ".-", color="tab:blue", lw=1, ms=3, label="network (shipped)")
            dev = path_deviation_m(n, g)
            ax.set_title(f"{sc.name} - {preset}: path deviation {dev:.2f} m", fontsize=9)
            ax.set_aspect("equal")
            ax.set_xlim(-0.5, 16.5)
            ax.set_ylim(-2.5, 2.5)
            ax.grid(alpha=0.3)
            if i == 0 and j == 0:
                ax.legend(fontsize=7, loc="lower left")
    fig.suptitle("Shipped networks (behind the safety filter, as gpcnav simulate runs them) against the GPC; "
                 "red: the obstacle", fontsize=10)
    fig.tight_layout()
    save_figure(fig, out, dpi=110)
    plt.close(fig)


def markdown(res: dict) -> str:
    L = ["# The shipped networks against the GPC", "",
         "Written by `python tools/evaluate_shipped.py` (" + res["when"] + ", " + res["machine"] + "). "
         "Path deviation: the largest distance from a sample of either run to the other run's path; same "
         "instant: the largest distance between the two robots at the same sample instant. `nn+filter` is "
         "the network behind the safety filter with the GPC on standby (`gpcnav simulate --controller nn "
         "--shield-fallback gpc`; plain `--controller nn` is the planner-free check, docs/nn-deploy.md); "
         "`nn bare` without the filter.", ""]
    for preset, m in res["models"].items():
        L.append(f"* `{preset}`: `{m['path']}`, {m['bytes']} bytes, {m['layers']} hidden layer(s) of "
                 f"{m['hidden']}, {m['passes']} pass(es), validation RMSE {m['validation_rmse_mps']:.4f} m/s")
    if "multi_model" in res:
        mm = res["multi_model"]
        L.append(f"* multi-obstacle (`random-multi`): `{mm['path']}`, layout `{mm['layout']}`, preset "
                 f"`{mm['preset']}`, {mm.get('passes', '?')} pass(es)")
    L += ["", "## Fig. 7 situations", "",
          "| preset | scenario | controller | outcome | min clearance (m) | fallbacks | path dev. (m) | "
          "same-instant dev. (m) |", "|---|---|---|---|---|---|---|---|"]
    for r in res["fig7"]:
        pd = f"{r['path_deviation_m']:.3f}" if "path_deviation_m" in r else "-"
        sd = f"{r['same_instant_deviation_m']:.3f}" if "same_instant_deviation_m" in r else "-"
        L.append(f"| {r['preset']} | {r['scenario']} | {r['controller']} | {r['outcome']} | "
                 f"{r['min_clearance_m']:.3f} | {r['fallbacks']} | {pd} | {sd} |")
    L += ["", "![Fig. 7, shipped networks](fig7_shipped.png)", ""]
    for title, key in (("Random suite (200 episodes, seed 1)", "random"),
                       ("Random-multi suite (200 episodes, seed 1), multi-obstacle model", "random-multi")):
        if key not in res:
            continue
        L += [f"## {title}", "", "| preset | controller | reached | collided | timed out | fallbacks | "
              "decision median (ms) |", "|---|---|---|---|---|---|---|"]
        for preset, rows in res[key].items():
            for name, r in rows.items():
                L.append(f"| {preset} | {name} | {100 * r['reached_goal']:.1f} % | {100 * r['collided']:.1f} % | "
                         f"{100 * r['timed_out']:.1f} % | {r['fallbacks']} | {1e3 * r['decision_median_s']:.3f} |")
        L.append("")
    L += ["## Encounters suite (the Fig. 7 family, bare network)", "",
          "| preset | episodes | GPC reached | network reached | network collided | path dev. median / p90 (m) | "
          "within 0.25 m (path) | same-instant median (m) | within 0.25 m (same instant) |",
          "|---|---|---|---|---|---|---|---|---|"]
    for preset, e in res["encounters"].items():
        L.append(f"| {preset} | {e['episodes']} | {100 * e['gpc_reached']:.0f} % | {100 * e['nn_reached']:.0f} % | "
                 f"{100 * e['nn_collided']:.0f} % | {e['path_deviation_median_m']:.3f} / {e['path_deviation_p90_m']:.3f} | "
                 f"{100 * e['within_0_25_m']:.0f} % | {e['same_instant_median_m']:.3f} | "
                 f"{100 * e['same_instant_within_0_25_m']:.0f} % |")
    return "\n".join(L) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=ROOT / "docs")
    ap.add_argument("--multi-model", type=Path, default=None)
    ap.add_argument("--encounters", type=int, default=100)
    args = ap.parse_args(argv)
    import os
    import platform
    res = {"when": time.strftime("%Y-%m-%d"), "machine": f"{platform.machine()}, {os.cpu_count()} cores",
           "models": {}, "fig7": [], "random": {}, "encounters": {}}
    all_paths = {}
    for preset in ("paper", "improved"):
        model = shipped_model_path(preset)
        p = OnnxPolicy(model, preset=preset)
        info = p.model_info
        res["models"][preset] = {"path": str(model.relative_to(ROOT)), "bytes": info["bytes"],
                                 "hidden": info["hidden"], "layers": info["layers"],
                                 "passes": 2 if p.two_pass else 1, "validation_rmse_mps": info["validation_rmse_mps"]}
        rows, paths = fig7_rows(preset, model)
        res["fig7"] += rows
        all_paths[preset] = paths
        for r in rows:
            print(r, flush=True)
        res["random"][preset] = suite_rows("random", 200, 1, preset, model, args.workers)
        res["encounters"][preset] = encounter_rows(preset, model, args.encounters, 1)
        print(preset, res["encounters"][preset], flush=True)
    if args.multi_model is not None:
        meta = OnnxPolicy(args.multi_model)
        preset = meta.config.name
        res["multi_model"] = {"path": str(args.multi_model), "preset": preset, "layout": meta.layout.name,
                              "passes": 2 if meta.two_pass else 1}
        res["random-multi"] = {preset: suite_rows("random-multi", 200, 1, preset, args.multi_model, args.workers)}
    figure(all_paths, args.out / "fig7_shipped.png")
    write_json(args.out / "data" / "shipped_models.json", res)
    write_text(args.out / "shipped_models.md", markdown(res))
    print(f"wrote {args.out / 'shipped_models.md'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
