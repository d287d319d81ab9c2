"""The study of issue 15: the paper's network on the paper's training distribution and on
today's, against networks of other sizes, with one and two passes (docs/nn-paper-study.md, "The paper's
network as the paper trained it").

    python tools/paper_nn_study.py --data NAME=DIR[:PART,PART][@SAMPLES] ... [--nets 35,64,64x2]
        [--passes 1,2] [--random 100] [--encounters 100] [--workers 2] [--out DIR]
        [--oracle] [--tie-margin REL]

``@SAMPLES`` trains on the dataset's first shards holding that many samples (a subset folder
of links under OUT/subsets: datasets labelled in one run compare on the same situations).
For every dataset and network: train (``gpcnav train --preset paper``, L-BFGS, seed 0,
skipped when the model folder exists; ``--nets 35+adam`` trains with Adam, ``--train-seed``
another seed), export once per number of passes, and measure:

* the paper's three Fig. 7 situations, bare network and behind the safety filter (GPC on
  standby): outcome, the largest distance from the GPC's path (as curves, and at the same
  sample instant, ``scenarios.metrics``), and whether every obstacle was passed on the
  GPC's side (``scenarios.metrics.passing_sides``);
* ``encounters`` (the Fig. 7 family, seed 1), bare: the share of episodes whose path stays
  within 0.25 m of the GPC's, the median distance, and the share passed on the GPC's side;
* ``random`` (seed 1): reached / collided, bare and behind the filter.

``--oracle`` adds the rows of the two-pass scheme with the GPC in place of the network
(:class:`nn_export.training.two_pass.TwoPassGPC`, first pass rolled out as the deployed
policy does, and as the GPC's open-loop plan): what a network that imitated its labels
exactly would do. Results accumulate in ``OUT/paper_nn_study.json`` (a row already there is
not redone) and the table in ``OUT/paper_nn_study.md``. A repository tool, not installed.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.io import write_json, write_text  # noqa: E402
from scenarios.metrics import passing_sides, path_deviation_m, same_instant_deviation_m  # noqa: E402
from casadi_gpc.pool import WorkerPool  # noqa: E402
from scenarios import paper_scenarios, random_suite  # noqa: E402

CONFIG = preset("paper")
_WORKER: dict = {}


def _controller(kind: str, model, safety: str, passes, robot, tie_margin):
    key = (kind, str(model), safety, passes, tie_margin)
    if key not in _WORKER:
        if kind.startswith("oracle"):
            from nn_export.training.labels import Labeller
            from nn_export.training.two_pass import TwoPassGPC
            _WORKER[key] = TwoPassGPC(Labeller(CONFIG, robot, tie_margin=tie_margin), kind.split("-")[1])
        else:
            from gpcnav.controllers import make_controller
            _WORKER[key] = make_controller(kind, CONFIG, robot, model, safety, passes)
    return _WORKER[key]


def _run(index, job):
    """Worker: one episode; returns the path, the obstacles' paths and the outcome."""
    from scenarios.simulator import simulate
    scenario, kind, model, safety, passes, tie_margin = job
    log = simulate(scenario, _controller(kind, model, safety, passes, scenario.robot, tie_margin), kind)
    return index, {"xy": np.asarray(log.states)[:, :2], "t": list(log.t), "obstacles": np.asarray(log.obstacle_xy),
                   "outcome": log.outcome, "fallbacks": int(log.fallbacks)}


def run_all(scenarios, kind, model=None, safety="off", passes=None, workers=2, tie_margin=None) -> list[dict]:
    jobs = [(i, (sc, kind, model, safety, passes, tie_margin)) for i, sc in enumerate(scenarios)]
    out = [None] * len(jobs)
    for i, r in WorkerPool(min(workers, len(jobs))).imap_unordered(_run, jobs):
        out[i] = r
    return out


def compare(runs, refs) -> list[dict]:
    """Each run against the GPC's run of the same scenario."""
    rows = []
    for n, g in zip(runs, refs):
        rows.append({"outcome": n["outcome"], "fallbacks": n["fallbacks"],
                     "path_m": path_deviation_m(n["xy"], g["xy"]),
                     "same_instant_m": same_instant_deviation_m(n["xy"], g["xy"], n.get("t"), g.get("t")),
                     "same_side": passing_sides(n["xy"], n["obstacles"]) == passing_sides(g["xy"], g["obstacles"])})
    return rows


def measure(kind, model, passes, gpc: dict, args, tie_margin=None) -> dict:
    """The row's measures (see the module docstring)."""
    t0 = time.perf_counter()
    fig7, enc, rnd = paper_scenarios(), random_suite("encounters", args.encounters, 1), random_suite(
        "random", args.random, 1)
    row = {"fig7": {}}
    safeties = ("off", "gpc") if kind == "nn" else ("off",)
    for safety in safeties:
        row["fig7"][safety] = compare(run_all(fig7, kind, model, safety, passes, args.workers, tie_margin), gpc["fig7"])
    e = compare(run_all(enc, kind, model, "off", passes, args.workers, tie_margin), gpc["encounters"])
    dev = np.array([x["path_m"] for x in e])
    row["encounters"] = {"episodes": len(e), "within_0_25_m": float(np.mean(dev <= 0.25)),
                         "median_m": float(np.median(dev)), "same_side": float(np.mean([x["same_side"] for x in e])),
                         "reached": float(np.mean([x["outcome"] == "reached_goal" for x in e])),
                         "collided": float(np.mean([x["outcome"] == "collided" for x in e]))}
    row["random"] = {}
    for safety in safeties if args.random else ():
        r = run_all(rnd, kind, model, safety, passes, args.workers, tie_margin)
        row["random"][safety] = {"episodes": len(r), "reached": float(np.mean([x["outcome"] == "reached_goal" for x in r])),
                                 "collided": float(np.mean([x["outcome"] == "collided" for x in r]))}
    row["seconds"] = time.perf_counter() - t0
    return row


def gpc_runs(args, cache: Path) -> dict:
    if cache.is_file():
        import pickle
        with open(cache, "rb") as fh:
            runs = pickle.load(fh)
        if len(runs["encounters"]) == args.encounters:
            return runs
    runs = {"fig7": run_all(paper_scenarios(), "gpc", workers=args.workers),
            "encounters": run_all(random_suite("encounters", args.encounters, 1), "gpc", workers=args.workers)}
    import pickle
    with open(cache, "wb") as fh:
        pickle.dump(runs, fh)
    return runs


def subset(data: str, samples: int, out: Path, restamp: bool = False) -> str:
    """A dataset folder of links to the first shards of ``data`` that hold ``samples``
    samples (every part in order), with its manifest cut to match. ``restamp``: write
    today's `paper` configuration into the manifest (for labels made before a change of
    planner settings that do not enter a label; the caller checks that they agree)."""
    src = Path(data).resolve()
    man = json.loads((src / "manifest.json").read_text())
    dst = out / f"{src.name}@{samples}"
    dst.mkdir(parents=True, exist_ok=True)
    left, total = samples, 0
    for part in man.get("parts", {}).values():
        kept = []
        for shard in part["shards"]:
            if left <= 0:
                break
            n = int(np.load(src / shard)["labels"].shape[0])
            kept.append(shard)
            left -= n
            total += n
            if not (dst / shard).exists():
                (dst / shard).symlink_to(src / shard)
        part["shards"], part["samples"] = kept, sum(int(np.load(src / s)["labels"].shape[0]) for s in kept)
    if restamp:
        man["planner_config_labelled"], man["planner_config"] = man.get("planner_config"), CONFIG.to_dict()
    man["samples"], man["shards"] = total, [s for part in man.get("parts", {}).values() for s in part["shards"]]
    write_json(dst / "manifest.json", man)
    return str(dst)


def train(data: str, parts: str | None, net: str, models: Path, seed: int = 0) -> Path:
    """Train (unless done) and return the model folder. ``net``: ``HIDDEN[xLAYERS][+adam]``
    (default full-batch L-BFGS)."""
    net_shape, _, optimizer = net.partition("+")
    hidden, _, layers = net_shape.partition("x")
    folder = models / (f"{Path(data).name}{'-' + parts.replace(',', '+') if parts else ''}-{net}"
                       f"{f'-s{seed}' if seed else ''}")
    if not (folder / "model.json").is_file():
        cmd = [sys.executable, "-m", "gpcnav", "train", data, "--out", str(folder), "--preset", "paper",
               "--seed", str(seed),
               "--hidden", hidden, "--layers", layers or "1", "--epochs", "400",
               "--optimizer", optimizer or "lbfgs"]
        if parts:
            cmd += ["--parts", parts]
        subprocess.run(cmd, check=True, cwd=ROOT)
    for passes in (1, 2):
        onnx = folder.with_name(folder.name + f"-p{passes}.onnx")
        if not onnx.is_file():
            subprocess.run([sys.executable, "-m", "gpcnav", "export", str(folder), "--out", str(onnx), "--passes",
                            str(passes)], check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
    return folder


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", nargs="*", default=[], metavar="NAME=DIR[:PARTS]")
    ap.add_argument("--models", nargs="*", default=[], metavar="NAME=MODEL.onnx",
                    help="rows for networks already trained (e.g. the shipped one), with their own passes")
    ap.add_argument("--nets", default="35,64,64x2")
    ap.add_argument("--passes", default="1,2")
    ap.add_argument("--random", type=int, default=100)
    ap.add_argument("--encounters", type=int, default=100)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "paper_nn_study")
    ap.add_argument("--train-seed", type=int, default=0, help="seed of the training (split, weights)")
    ap.add_argument("--oracle", action="store_true")
    ap.add_argument("--restamp", action="store_true",
                    help="train datasets labelled under an earlier `paper` configuration (see subset())")
    ap.add_argument("--tie-margin", type=float, default=None, help="the oracle's labels' near-tie margin")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    results_path = args.out / "paper_nn_study.json"
    results = json.loads(results_path.read_text()) if results_path.is_file() else {}
    gpc = gpc_runs(args, args.out / "gpc_runs.pkl")
    todo = []
    if args.oracle:
        for mode in ("rollout", "plan"):
            todo.append((f"oracle-{mode}-m{args.tie_margin}", f"oracle-{mode}", None, 2, args.tie_margin))
    for spec in args.data:
        name, _, rest = spec.partition("=")
        rest, _, samples = rest.partition("@")
        data, _, parts = rest.partition(":")
        if samples or args.restamp:
            data = subset(data, int(samples or 10 ** 9), args.out / "subsets", args.restamp)
        for net in args.nets.split(","):
            folder = train(data, parts or None, net, args.out / "models", args.train_seed)
            for passes in (int(p) for p in args.passes.split(",")):
                seed = f"-s{args.train_seed}" if args.train_seed else ""
                todo.append((f"{name}-{net}{seed}-p{passes}", "nn", folder.with_name(folder.name + f"-p{passes}.onnx"),
                             passes, None))
    for spec in args.models:
        name, _, path = spec.partition("=")
        todo.append((name, "nn", Path(path), None, None))
    for key, kind, model, passes, margin in todo:
        if key in results:
            continue
        print(f"measuring {key} ...", flush=True)
        row = measure(kind, model, passes, gpc, args, margin)
        if model is not None:
            from nn_export.runtime.policy import OnnxPolicy
            info = OnnxPolicy(model, preset="paper").model_info
            row["validation_rmse_mps"] = info["validation_rmse_mps"]
            row["samples"] = info["dataset"].get("samples")
            row["network"] = f"17-{'-'.join([str(info['hidden'])] * info['layers'])}-2"
        results[key] = row
        write_json(results_path, results)
        print(key, json.dumps({k: v for k, v in row.items() if k != "fig7"}),
              [(round(x["path_m"], 2), x["same_side"], x["outcome"][:7]) for x in row["fig7"]["off"]], flush=True)
    write_text(args.out / "paper_nn_study.md", table(results))
    return 0


def _pct(x) -> str:
    return f"{100 * x:.0f}"


def table(results: dict) -> str:
    L = ["| row | val. RMSE (m/s) | Fig. 7 path dev. 7.1 / 7.2 / 7.3 (m), bare | same instant (m) | GPC's side | "
         "Fig. 7 behind the filter (path, m) | encounters within 0.25 m / median (m) / GPC's side | "
         "random reached / collided, bare (%) | behind the filter (%) |",
         "|---|---|---|---|---|---|---|---|---|"]
    for key, r in results.items():
        f = r["fig7"]["off"]
        flt = r["fig7"].get("gpc")
        mark = lambda x: "" if x["outcome"] == "reached_goal" else f" ({x['outcome'].replace('_', ' ')})"  # noqa: E731
        e = r["encounters"]
        rb, rf = r["random"].get("off"), r["random"].get("gpc")
        L.append(
            f"| {key} | {r.get('validation_rmse_mps', float('nan')):.3f} | "
            + " / ".join(f"{x['path_m']:.2f}{mark(x)}" for x in f) + " | "
            + " / ".join(f"{x['same_instant_m']:.2f}" for x in f) + " | "
            + " ".join("yes" if x["same_side"] else "**no**" for x in f) + " | "
            + (" / ".join(f"{x['path_m']:.2f}{mark(x)}" for x in flt) if flt else "-") + " | "
            + f"{_pct(e['within_0_25_m'])} % / {e['median_m']:.2f} / {_pct(e['same_side'])} % | "
            + (f"{_pct(rb['reached'])} / {_pct(rb['collided'])}" if rb else "-") + " | "
            + (f"{_pct(rf['reached'])} / {_pct(rf['collided'])}" if rf else "-") + " |")
    return "\n".join(L) + "\n"


if __name__ == "__main__":
    raise SystemExit(main())
