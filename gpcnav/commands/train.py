"""Train the wheel-speed network on one or more dataset directories (from ``gpcnav
dataset``, with any on-policy parts) and write a model folder: weights, model.json with the
provenance that ``gpcnav export`` puts into the ONNX file, and the training curve (the
paper's Fig. 6) as training_curve.json and training_curve.png."""
from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

from ..errors import UsageError, comma_items
from .common import (add_preset_arguments, check_name_lengths, check_seed, check_writable_folder, config_differences,
                     planner_config, progress)


def add_arguments(p):
    p.add_argument("datasets", type=Path, nargs="+", metavar="DATASET_DIR", help="dataset folder(s) to train on")
    p.add_argument("--out", type=Path, required=True, help="model folder to write")
    p.add_argument("--hidden", type=int, default=35, help="hidden units per layer (paper: 35)")
    p.add_argument("--layers", type=int, default=1, help="hidden layers, 1 to 4 (paper: 1)")
    p.add_argument("--parts", default=None, metavar="LIST",
                   help="train on these parts of the dataset(s) only, comma-separated (e.g. offpolicy,gpc1; "
                        "default all): what each on-policy round adds")
    p.add_argument("--activation", choices=("tanh", "relu", "softsign"), default="tanh", help="hidden non-linearity")
    p.add_argument("--architecture", choices=("mlp", "set"), default="mlp",
                   help="mlp (default): a perceptron on the whole input row; set: the obstacles of the set layout "
                        "encoded alike and pooled, so their order does not matter (nn_export/training/set_net.py)")
    p.add_argument("--target", choices=("command", "plan"), default="command",
                   help="what the network outputs: the first command (default) or the GPC's whole H-step plan "
                        "of wheel speeds (checked as a plan behind the check layer; docs/nn.md)")
    p.add_argument("--encoder-width", type=int, default=None,
                   help="--architecture set: units of the obstacle encoder (default 64)")
    p.add_argument("--relative", action="store_true",
                   help="learn the change from the current wheel speeds (the GPC decides increments); the exported "
                        "graph adds them back, so the model file answers wheel speeds as any other")
    p.add_argument("--layout", choices=("paper", "multi", "set", "set-walls"), default=None,
                   help="feature layout the datasets must have (default: whatever they have)")
    p.add_argument("--output-basis", choices=("speed_turn", "wheels"), default="speed_turn",
                   help="learn (mean speed, half difference) (default) or the two wheel speeds directly")
    p.add_argument("--optimizer", choices=("lbfgs", "adam"), default="lbfgs",
                   help="full-batch L-BFGS (default) or mini-batch Adam")
    p.add_argument("--epochs", type=int, default=400,
                   help="maximum L-BFGS steps (10 iterations each) or Adam epochs (early stopping ends sooner)")
    p.add_argument("--patience", type=int, default=40,
                   help="steps/epochs without a better validation error before stopping")
    p.add_argument("--batch-size", type=int, default=None, help="--optimizer adam: mini-batch size (default 1024)")
    p.add_argument("--lr", type=float, default=None, help="--optimizer adam: initial learning rate (default 0.003)")
    p.add_argument("--weight-decay", type=float, default=0.0, help="L2 penalty")
    p.add_argument("--cost-gap-weight", type=float, default=None, metavar="SCALE",
                   help="weigh each label by how much dearer the runner-up optimum of its multi-start was, relative "
                        "to its cost: a gap of SCALE or more counts fully, a near tie down to a tenth "
                        "(nn_export/training/weights.py; against averaging the two sides of an obstacle)")
    p.add_argument("--validation-fraction", type=float, default=0.15, help="share of situations held out")
    p.add_argument("--seed", type=int, default=0, help="seeds the split, the initial weights and the batch order")
    p.add_argument("--init", type=Path, default=None, metavar="MODEL.onnx",
                   help="train this exported set network further (its weights, standardisation and output basis) on "
                        "the datasets, of its layout; --architecture set, --relative and --hidden, --layers, "
                        "--encoder-width and --activation as its own (default: fresh weights)")
    add_preset_arguments(p)



def _label_names(names, steps: int, target: str):
    """The output names: the dataset's (one command), or each plan step's ``<name>_<k>``."""
    if target == "command" or names is None:
        return names
    return [f"{n}_{k}" for k in range(1, steps + 1) for n in names]


def _dataset_id(manifests, parts: tuple[str, ...] | None = None) -> str:
    """A short hash of what was trained on: each dataset's manifest (samples, shards, seed) and
    the parts taken from it, ``parts`` (``--parts``) or all (None). Naming every part is the
    same data, so the same id; other parts of the same folders are another id (until
    2026-12-02 the id hashed every part whatever ``--parts`` said)."""
    import json
    h = hashlib.sha256()
    for m in manifests:
        key = {k: m.get(k) for k in ("samples", "shards", "parts", "seed")}
        if parts is not None and isinstance(key["parts"], dict):
            key["parts"] = {k: v for k, v in key["parts"].items() if k in parts}
        h.update(json.dumps(key, sort_keys=True, default=str).encode())
    return h.hexdigest()[:16]


def _check_distinct(datasets) -> None:
    """Refuse a dataset folder given twice (``d`` and ``./d``, a link to it): each copy's
    situations got their own ids, so copies of one situation fell on both sides of the
    split and the validation error measured samples trained on."""
    import os
    seen = {}
    for d in datasets:
        try:
            key = (os.stat(d).st_dev, os.stat(d).st_ino)
        except OSError:
            key = Path(d).resolve()
        if key in seen:
            raise UsageError(f"{d}: the same dataset folder as {seen[key]}, given twice (its samples would be "
                             f"both trained on and validated on)")
        seen[key] = d


def _init_network(args) -> dict | None:
    """``--init``'s network (:func:`nn_export.training.warm_start.read_set_network`), its shape
    checked against the options given; None without it."""
    if args.init is None:
        return None
    from nn_export.training.warm_start import read_set_network
    try:
        init = read_set_network(args.init)
    except ValueError as exc:
        raise UsageError(f"--init {args.init}: {str(exc).removeprefix(f'{args.init}: ')}") from None
    if init["preset"] != args.preset:
        raise UsageError(f"--init {args.init}: a network of preset {init['preset']!r}, not --preset {args.preset}")
    width = 64 if args.encoder_width is None else args.encoder_width  # (the set network's default)
    for name, own, given in (("--architecture", "set", args.architecture), ("--relative", True, args.relative),
                             ("--hidden", init["hidden"], args.hidden), ("--layers", init["layers"], args.layers),
                             ("--encoder-width", init["encoder_width"], width),
                             ("--activation", init["activation"], args.activation)):
        if own != given:
            raise UsageError(f"--init {args.init}: the network's {name} is {own}, this training's {given}: give "
                             f"{name} as its own")
    return init


def run(args) -> int:
    import numpy as np
    _check_distinct(args.datasets)
    try:
        from nn_export.training.train import WheelSpeedMLP
    except ImportError as exc:
        raise UsageError(f"training needs the train extra (pip install -e '.[train]'): {exc}") from None
    from nn_export.training.dataset import load_dataset, read_manifest
    cfg = planner_config(args)
    check_seed(args.seed)
    from nn_export.runtime.model_file import timing_mismatch
    if timing_mismatch(cfg.name, cfg.horizon, cfg.sample_time_s):  # export wrote it, every command refused it
        from casadi_gpc.config import preset as preset_config
        base = preset_config(cfg.name)
        raise UsageError(f"--horizon/--sample-time: H={cfg.horizon}, T={cfg.sample_time_s} s but preset {cfg.name!r} "
                         f"has H={base.horizon}, T={base.sample_time_s} s: a policy runs a network at its preset's "
                         f"horizon and sample time, and every command would refuse this one")
    out = Path(args.out)
    check_name_lengths(out, f"--out {out}")
    if out.exists() and not out.is_dir():  # found only after the training, as a traceback
        raise UsageError(f"--out {out}: a file, where the trained model's folder goes")
    check_writable_folder(out, f"--out {out}")
    if not 1 <= args.layers <= 4:
        raise UsageError(f"--layers must be from 1 to 4, got {args.layers}")
    set_net, adam = args.architecture == "set", args.optimizer == "adam"
    for name, given, used, of in (("--encoder-width", args.encoder_width, set_net, "--architecture set"),
                                  ("--batch-size", args.batch_size, adam, "--optimizer adam"),
                                  ("--lr", args.lr, adam, "--optimizer adam")):
        if given is not None and not used:  # (taken and ignored: the same network as without it)
            raise UsageError(f"{name}: an option of {of}, which this training does not use")
    for name, v, lo in (("--hidden", args.hidden, 1), ("--epochs", args.epochs, 1), ("--patience", args.patience, 1),
                        ("--encoder-width", args.encoder_width, 1),
                        ("--batch-size", args.batch_size, 1)):
        if v is not None and v < lo:
            raise UsageError(f"{name} must be at least {lo}, got {v}")
    if args.lr is not None and not args.lr > 0:
        raise UsageError(f"--lr must be positive, got {args.lr}")
    if not 0 <= args.weight_decay < float("inf"):  # -1 trained, rewarding large weights; nan "diverged (learning_rate)"
        raise UsageError(f"--weight-decay must be a finite number, 0 or more, got {args.weight_decay}")
    if args.cost_gap_weight is not None and not args.cost_gap_weight > 0:
        raise UsageError(f"--cost-gap-weight must be positive, got {args.cost_gap_weight}")
    if not 0 < args.validation_fraction < 1:
        raise UsageError(f"--validation-fraction must be in (0, 1), got {args.validation_fraction}")
    init = _init_network(args)
    parts = None if args.parts is None else tuple(comma_items(args.parts, "--parts"))
    if parts is not None:
        for d in args.datasets:
            have = set(read_manifest(d).get("parts", {})) if (Path(d) / "manifest.json").is_file() else set()
            missing = [x for x in parts if x not in have]
            if have and missing:
                raise UsageError(f"{d}: no part {', '.join(missing)} (it has {', '.join(sorted(have))})")
    sets = []
    for d in args.datasets:
        if not (d / "manifest.json").is_file():
            raise UsageError(f"{d}: not a dataset folder (no manifest.json)")
        try:
            sets.append(load_dataset(d, parts, args.target))
        except KeyError as exc:  # a manifest without a field every dataset has
            raise UsageError(f"{d}: cannot read the dataset: its manifest.json has no {exc.args[0]!r}") from None
        except (ValueError, OSError) as exc:
            text = str(exc)
            raise UsageError(f"{d}: cannot read the dataset: {text.removeprefix(f'{d}: ')}") from None
    first = sets[0]
    cfg = cfg.for_walls(bool(first.layout.wall_sectors))  # a layout that reads walls was labelled with wall slots
    for d, s in zip(args.datasets, sets):
        man = s.manifest
        if man.get("complete") is False:  # said, not silent: a stopped `dataset` resumes with its command
            print(f"gpcnav train: warning: {d} holds {man.get('samples')} of the {man.get('samples_requested', '?')} "
                  f"samples asked (its `gpcnav dataset` run stopped; the same command finishes it): training on "
                  f"those", file=sys.stderr)
        if man.get("preset") != cfg.name:
            raise UsageError(f"{d}: dataset labelled under preset {man.get('preset')!r}, not --preset {cfg.name}")
        differ = config_differences(man.get("planner_config") or {}, cfg.to_dict())
        if differ:
            raise UsageError(f"{d}: dataset labelled with another planner configuration than preset {cfg.name!r} "
                             f"({', '.join(differ)} {'differ' if len(differ) > 1 else 'differs'})")
        if args.layout is not None and s.layout.name != args.layout:
            raise UsageError(f"{d}: dataset has feature layout {s.layout.name!r}, not --layout {args.layout}")
        if s.layout != first.layout or man.get("robot") != first.manifest.get("robot"):
            raise UsageError(f"{d}: feature layout or robot differs from {args.datasets[0]}")
    if args.architecture == "set" and not first.layout.is_set:
        raise UsageError(f"--architecture set needs a dataset of the set layout, not {first.layout.name!r} "
                         f"(gpcnav dataset --layout set)")
    if init is not None and tuple(init["feature_names"]) != tuple(first.layout.feature_names):
        raise UsageError(f"--init {args.init}: a network of the {init['layout']!r} layout, the datasets' is "
                         f"{first.layout.name!r}" + (" (another version of it)" if init["layout"] == first.layout.name
                                                     else ""))
    X = np.concatenate([s.X for s in sets])
    Y = np.concatenate([s.Y for s in sets])
    # situation ids are unique within a dataset; offset them so that datasets do not collide
    G = np.concatenate([s.groups.astype(np.int64) * len(sets) + i for i, s in enumerate(sets)])
    weights, weighting = None, None
    if args.cost_gap_weight is not None:
        from nn_export.training.weights import WEIGHT_FLOOR, cost_gap_weights
        weights = np.concatenate([cost_gap_weights(s.candidate_costs, s.cost, args.cost_gap_weight) for s in sets])
        weighting = {"kind": "cost_gap", "scale": args.cost_gap_weight, "floor": WEIGHT_FLOOR,
                     "mean": float(weights.mean()), "below_one": int(np.sum(weights < 1.0))}
    given = {k: v for k, v in (("batch_size", args.batch_size), ("learning_rate", args.lr),
                               ("encoder_width", args.encoder_width)) if v is not None}  # else the model's defaults
    model = WheelSpeedMLP(hidden=args.hidden, layers=args.layers, activation=args.activation, output_basis=args.output_basis,
                          optimizer=args.optimizer, max_epochs=args.epochs, weight_decay=args.weight_decay,
                          validation_fraction=args.validation_fraction, patience=args.patience,
                          random_state=args.seed, architecture=args.architecture, relative=args.relative, **given)
    bar = progress(total=args.epochs, desc="training", unit="it")

    def tick(epoch, tr, va):
        bar.update(1)
        bar.set_postfix_str(f"train {tr:.2e}  val {va:.2e} (m/s)^2", refresh=False)

    try:
        model.fit(X, Y, groups=G, feature_names=first.layout.feature_names,
                  label_names=_label_names(first.manifest.get("label_names"), Y.shape[1] // 2, args.target),
                  progress=tick, sample_weight=weights, init_state=None if init is None else init["state"])
    except (ValueError, FloatingPointError) as exc:
        raise UsageError(f"training failed: {exc}") from None
    finally:
        bar.close()
    lay = first.layout
    provenance = {
        "preset": cfg.name, "horizon": cfg.horizon, "sample_time_s": cfg.sample_time_s, "output": args.target,
        "planner_config": cfg.to_dict(), "robot": first.manifest["robot"], "feature_layout": lay.name,
        "feature_layout_version": lay.version, "feature_layout_spec": lay.to_dict(),
        "dataset": {"id": _dataset_id([s.manifest for s in sets], parts), "paths": [str(d) for d in args.datasets],
                    "samples": int(len(X)),
                    "parts": {str(d): sorted(x for x in s.manifest.get("parts", {}) if parts is None or x in parts)
                              for d, s in zip(args.datasets, sets)}},
    }
    if weighting is not None:
        provenance["training"] = {"sample_weights": weighting}  # into the file's trained_with
    if init is not None:  # the network trained further, and what it was trained on before
        provenance.setdefault("training", {})["init"] = {
            "model": args.init.name, "sha256": hashlib.sha256(args.init.read_bytes()).hexdigest(),
            "dataset": json.loads(init["metadata"].get("dataset") or "{}")}
    model.save(args.out, provenance, {"validation_features": X[model.validation_indices_]})
    shape = f"{X.shape[1]}-{'-'.join([str(args.hidden)] * args.layers)}-{Y.shape[1]}"
    if args.architecture == "set":
        rho = "-".join([str(args.hidden)] * args.layers)
        shape = f"set encoder {model.encoder_width}-{model.encoder_width}, max+sum pool, {rho}-{Y.shape[1]}"
    print(f"trained {lay.name} layout ({shape}) on {len(model.train_indices_)} samples, "
          f"validated on {len(model.validation_indices_)}: validation RMSE {np.sqrt(model.validation_mse_):.4f} m/s "
          f"(max {model.validation_max_abs_error_:.3f}), best epoch {model.best_epoch_} ({model.stop_reason_}), "
          f"wrote {args.out}", file=sys.stdout)
    return 0
