"""The paper end to end: label the paper's training distribution with the GPC (its two
passes: tracking situations without obstacles, and the robot on its predicted path with an
obstacle; ``Sizes`` holds the recipe), train the paper's network (17-35-2) and export it to
run the paper's two passes, run the three Fig. 7 scenarios with the GPC and the network
(bare, as the paper ran it, and behind the safety filter), run the two-pass scheme with the
GPC in place of the network (the scheme's own limit), run the random suite with both, run
the solver benchmark, and write figures, tables, report.md and results.json into --out.
The pipeline runs under ``--preset`` (default `paper`: the paper reproduced; `improved` runs the
same pipeline, the paper's scheme and network, under the `improved` planner); the full run's
tables add the other preset's rows (its GPC, and the network shipped for it) on the same
scenarios and suite.

Each stage records a key of its inputs in DIR/stages.json; a stage whose outputs exist with
the same key is not redone, so a stopped run picks up where it was."""
from __future__ import annotations

import hashlib
import json
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from casadi_gpc.config import PRESETS
from casadi_gpc.io import write_json

from ..errors import UsageError
from .common import check_seed, make_output_folder, usable_cores
from .reproduce_report import write_report


@dataclass(frozen=True)
class Sizes:
    """How much work each stage does, and the recipe of the paper's network (the study behind
    the choice: docs/nn-paper-study.md, "The paper's network as the paper trained it")."""

    scheme: str
    """The labelled situations: ``two-pass`` (the paper's distribution: first-pass tracking
    situations and second-pass situations on the predicted path, ``gpcnav dataset --scheme
    two-pass``) or ``sampled`` (sampled situations, then the DART rounds below)."""
    samples: int
    tie_margin: float | None
    """The labels' near-tie margin (``gpcnav dataset --tie-margin``); None: the planner's choice."""
    dart_random_episodes: int
    """GPC-driven episodes of the random suite, wheel speeds perturbed by N(0, 0.05) m/s,
    starts up to 1.2 m beside the path (``sampled`` only)."""
    dart_encounter_episodes: int
    """GPC-driven episodes of the encounters suite, perturbed by N(0, 0.03) m/s (``sampled`` only)."""
    epochs: int
    suite_count: int
    improved: bool
    """Add the other preset's rows (its GPC and shipped network) to the tables."""


QUICK = Sizes(scheme="two-pass", samples=6000, tie_margin=None, dart_random_episodes=0, dart_encounter_episodes=0,
              epochs=400, suite_count=16, improved=False)
FULL = Sizes(scheme="two-pass", samples=21000, tie_margin=None, dart_random_episodes=0, dart_encounter_episodes=0,
             epochs=400, suite_count=100, improved=True)
"""The recipe from the study (docs/nn-paper-study.md, "The paper's network as the paper trained it"): the
paper's two-pass distribution, two passes, the planner's own choice at near ties (with the
1 % margin the 17-35-2 passed Fig. 7.1's obstacle on the other side in both training seeds,
without it on the GPC's), 21000 samples (100000 brought it no closer to the GPC, and L-BFGS
on them took 7 min); ``--quick`` labels 6000 to stay under 3 minutes."""
PASSES = 2
"""The paper's two passes."""
LIMIT_MODES = ("rollout", "plan")
"""The first pass of the two-pass GPC rows (:class:`nn_export.training.two_pass.TwoPassGPC`)."""
TABLE_ORDER = ("paper", "improved")
"""The presets, in the order the full run's tables list them."""


def add_arguments(p):
    p.add_argument("--out", type=Path, required=True, help="output folder (created; a stopped run resumes)")
    p.add_argument("--quick", action="store_true",
                   help="a smaller dataset and suite, the run's preset only (< 3 min on 2 cores)")
    p.add_argument("--preset", choices=sorted(PRESETS), default="paper",
                   help="the planner the pipeline labels with, trains for and runs (default: paper, the paper "
                        "reproduced; improved: the same scheme and network under the improved planner)")
    p.add_argument("--seed", type=int, default=0, help="seed of the dataset, the training and the suite")
    p.add_argument("--workers", type=int, default=usable_cores(), help="worker processes (default: one a core)")


def _cli(argv: list[str]) -> None:
    from ..cli import main
    code = main([str(a) for a in argv])
    if code:
        raise UsageError(f"stage command failed (exit {code}): gpcnav {' '.join(map(str, argv))}")


class _Stages:
    """Runs stages in order, skipping those whose outputs exist with the same input key."""

    def __init__(self, out: Path):
        self.out = out
        self.path = out / "stages.json"
        self.done = json.loads(self.path.read_text()) if self.path.is_file() else {}
        self.timing: dict[str, float] = {}

    def run(self, name: str, inputs: dict, outputs: list[Path], fn) -> None:
        key = hashlib.sha256(json.dumps(inputs, sort_keys=True, default=str).encode()).hexdigest()[:16]
        inputs_for_later = key
        if self.done.get(name, {}).get("key") == key and all(p.exists() for p in outputs):
            print(f"[reproduce] {name}: up to date, skipped", file=sys.stderr, flush=True)
            self.timing[name] = self.done[name].get("seconds", 0.0)
            return
        print(f"[reproduce] {name} ...", file=sys.stderr, flush=True)
        t0 = time.perf_counter()
        fn()
        seconds = time.perf_counter() - t0
        self.timing[name] = seconds
        self.done[name] = {"key": inputs_for_later, "seconds": seconds}
        write_json(self.path, self.done)
        print(f"[reproduce] {name}: done in {seconds:.1f} s", file=sys.stderr, flush=True)

    def key(self, name: str) -> str:
        return self.done.get(name, {}).get("key", "")


def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16] if path.is_file() else "missing"


def run(args) -> int:
    if args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    check_seed(args.seed)
    sizes = QUICK if args.quick else FULL
    out: Path = args.out
    make_output_folder(out, "--out")
    st = _Stages(out)
    t_start = time.perf_counter()
    trained = args.preset
    presets = TABLE_ORDER if sizes.improved else (trained,)
    onnx = _label_train_export(st, out, sizes, args.seed, args.workers, trained)
    model_key = _file_digest(onnx)
    run_files = _scenario_runs(st, out / "runs", onnx, model_key, presets, trained)
    limit_files = _scheme_limit(st, out / "runs", sizes, trained)
    eval_files = _suite_runs(st, out / "eval", onnx, model_key, sizes.suite_count, args.seed, args.workers, presets,
                             trained)
    bench = _bench(st, out, onnx, model_key, trained)
    # total work: the stages' own times (a resumed run reuses finished stages and their times)
    write_report(out, sizes, args, run_files, eval_files, bench, st.timing, sum(st.timing.values()), environment(),
                 limit_files)
    print(f"[reproduce] wrote {out / 'report.md'} in {time.perf_counter() - t_start:.0f} s", file=sys.stderr)
    return 0


def _label_train_export(st: _Stages, out: Path, sizes: Sizes, seed: int, workers: int, trained: str) -> Path:
    """1. the labels (resumable by themselves), 2. the GPC's own states (DART rounds, the
    ``sampled`` scheme), 3. training and export, all under the preset ``trained``; returns the
    model file."""
    data, model_dir, onnx = out / "dataset", out / "model", out / "model.onnx"
    tie = [] if sizes.tie_margin is None else ["--tie-margin", sizes.tie_margin]
    st.run("dataset", {"samples": sizes.samples, "seed": seed, "scheme": sizes.scheme, "tie_margin": sizes.tie_margin,
                       **_preset_key(trained)},
           [data / "manifest.json"], lambda: _cli(
               ["dataset", "--out", data, "--samples", sizes.samples, "--preset", trained, "--seed", seed,
                "--workers", workers, "--scheme", sizes.scheme, *tie]))
    rounds = ((1, "random", sizes.dart_random_episodes, ["--dagger-noise", 0.05, "--start-offset", 1.2]),
              (2, "encounters", sizes.dart_encounter_episodes, ["--dagger-noise", 0.03]))

    def onpolicy():
        for r, suite, episodes, extra in rounds:
            man = json.loads((data / "manifest.json").read_text())
            if episodes and f"gpc{r}" not in man.get("parts", {}):
                _cli(["dataset", "--out", data, "--dagger", "gpc", "--dagger-suite", suite, "--round", r,
                      "--episodes", episodes, "--preset", trained, "--seed", seed, "--workers", workers, *extra, *tie])
    if any(r[2] for r in rounds):
        st.run("onpolicy", {"dataset": st.key("dataset"), "rounds": [r[:3] for r in rounds]},
               [data / "manifest.json"], onpolicy)

    def train():
        _cli(["train", data, "--out", model_dir, "--preset", trained, "--seed", seed, "--epochs", sizes.epochs])
        _cli(["export", model_dir, "--out", onnx, "--passes", PASSES])
    st.run("train", {"data": st.key("onpolicy") or st.key("dataset"), "epochs": sizes.epochs, "seed": seed,
                     "passes": PASSES}, [onnx], train)
    return onnx


def _preset_key(trained: str) -> dict:
    """The run's preset in a stage's key (left out for `paper`, so that a run begun before
    ``--preset`` existed resumes as it was)."""
    return {} if trained == "paper" else {"preset": trained}


def _scenario_runs(st: _Stages, runs: Path, onnx: Path, model_key: str, presets, trained: str) -> dict:
    """5. the Fig. 7 scenarios: the GPC, and the network bare (``nn``, as the paper ran it)
    and behind the safety filter (``nn+filter``); the ``trained`` preset's network is the one
    just trained, the other's the shipped. When `paper` is trained, also the network shipped
    for it, bare (``shipped``: the smallest network the study found to meet the claim)."""
    from scenarios import PAPER_DIR, PAPER_NAMES
    run_files = {}
    for preset_name in presets:
        for name in PAPER_NAMES:
            for ctrl in ("gpc", "nn", "nn+filter") + (("shipped",) if preset_name == trained == "paper" else ()):
                run_files[(preset_name, name, ctrl)] = runs / f"{name}_{preset_name}_{ctrl}.json"

    def scenario_runs():
        for (preset_name, name, ctrl), path in run_files.items():
            argv = ["simulate", PAPER_DIR / f"{name}.toml", "--controller", "gpc" if ctrl == "gpc" else "nn",
                    "--preset", preset_name, "--out", path]
            if ctrl in ("nn", "shipped"):
                argv.append("--no-safety-filter")
            if ctrl in ("nn", "nn+filter") and preset_name == trained:
                argv += ["--model", onnx]
            _cli(argv)
    st.run("scenarios", {"model": model_key, "presets": presets, **_preset_key(trained)}, list(run_files.values()),
           scenario_runs)
    return run_files


def _scheme_limit(st: _Stages, runs: Path, sizes: Sizes, trained: str) -> dict:
    """6. the paper's two-pass scheme with the GPC in place of the network on the Fig. 7
    scenarios (:class:`nn_export.training.two_pass.TwoPassGPC`, labels as the dataset's):
    how close a network that imitated its labels exactly would come, with the first pass
    rolled out step by step as the deployed policy does (``rollout``) and, for comparison,
    the GPC's obstacle-free open-loop plan as the prediction (``plan``, which no network
    with two outputs can give). Keys ``(scenario, mode)``."""
    from scenarios import PAPER_NAMES
    files = {(name, mode): runs / f"{name}_{trained}_two-pass-gpc-{mode}.json" for name in PAPER_NAMES
             for mode in LIMIT_MODES}

    def limit():
        from casadi_gpc.config import preset
        from casadi_gpc.io import write_json
        from scenarios.metrics import run_document
        from scenarios.simulator import simulate
        from nn_export.training.labels import Labeller
        from nn_export.training.two_pass import TwoPassGPC
        from scenarios import paper_scenarios
        config = preset(trained)
        for sc in paper_scenarios():
            for mode in LIMIT_MODES:
                oracle = TwoPassGPC(Labeller(config, sc.robot, tie_margin=sizes.tie_margin), mode)
                write_json(files[(sc.name, mode)],
                           run_document(simulate(sc, oracle, f"two-pass-gpc-{mode}"), {"preset": trained}))
    st.run("scheme_limit", {"tie_margin": sizes.tie_margin, "modes": LIMIT_MODES, **_preset_key(trained)},
           list(files.values()), limit)
    return files


def _suite_runs(st: _Stages, evals: Path, onnx: Path, model_key: str, count: int, seed: int, workers: int,
                presets, trained: str) -> dict:
    """7. the random suite, both controllers (the network behind the safety filter)."""
    eval_files = {(p, c): evals / f"random_{p}_{c}.json" for p in presets for c in ("gpc", "nn")}

    def suite_runs():
        for (preset_name, ctrl), path in eval_files.items():
            argv = ["evaluate", "--suite", "random", "--count", count, "--seed", seed, "--controller", ctrl,
                    "--preset", preset_name, "--workers", workers, "--out", path]
            if ctrl == "nn" and preset_name == trained:
                argv += ["--model", onnx]
            _cli(argv)
    st.run("suite", {"model": model_key, "count": count, "seed": seed, "presets": presets, **_preset_key(trained)},
           list(eval_files.values()), suite_runs)
    return eval_files


def _bench(st: _Stages, out: Path, onnx: Path, model_key: str, trained: str) -> Path:
    """8. the benchmark: the GPC solvers and the network paths on the same recorded problems (the
    crowd's decisions not pooled over ten crossings: the paper's network is not a crowd's, and
    under `improved` the pooling took most of a quick run)."""
    from scenarios import PAPER_DIR
    bench = out / "bench.json"
    st.run("bench", {"model": model_key, **_preset_key(trained)}, [bench], lambda: _cli(
        ["bench", PAPER_DIR / "fig7_2_crossing.toml", "--preset", trained, "--model", onnx, "--crowd-episodes", 0,
         "--out", bench, "--plot", out / "bench_solvers.png"]))
    return bench


def environment() -> dict:
    import casadi
    import numpy
    import onnxruntime
    env = {"python": platform.python_version(), "numpy": numpy.__version__, "casadi": casadi.__version__,
           "onnxruntime": onnxruntime.__version__, "platform": platform.platform(), "cpus": os.cpu_count()}
    try:
        import torch
        env["torch"] = torch.__version__
    except ImportError:
        env["torch"] = None
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                env["cpu"] = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return env
