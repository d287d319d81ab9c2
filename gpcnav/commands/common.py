"""Options and wiring shared by the subcommands."""
from __future__ import annotations

import argparse
from pathlib import Path

from casadi_gpc.config import DEFAULT_PRESET, PRESETS, preset

from ..errors import UsageError


def add_preset_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--preset", choices=sorted(PRESETS), default=DEFAULT_PRESET,
                   help=f"planner preset (default {DEFAULT_PRESET})")
    p.add_argument("--sample-time", type=float, default=None, metavar="T",
                   help="override the preset's sample time, s")
    p.add_argument("--horizon", type=int, default=None, metavar="H", help="override the preset's horizon")


def planner_config(args):
    cfg = preset(args.preset)
    if args.sample_time is not None and not args.sample_time > 0:
        raise UsageError(f"--sample-time must be positive, got {args.sample_time}")
    if args.horizon is not None and args.horizon < 1:
        raise UsageError(f"--horizon must be at least 1, got {args.horizon}")
    return cfg.with_overrides(sample_time_s=args.sample_time, horizon=args.horizon)


def add_controller_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--controller", choices=("gpc", "nn"), default="gpc", help="the GPC planner or the network")
    p.add_argument("--model", type=Path, default=None,
                   help="ONNX model for --controller nn (default: the one shipped for --preset)")
    add_preset_arguments(p)


def make_controller(kind: str, config, robot, model=None):
    """The controller object for ``kind`` (both answer ``decide(observation)``)."""
    if kind == "gpc":
        from casadi_gpc.gpc import GPCController
        return GPCController(config, robot)
    if kind == "nn":
        try:
            from nn_export import OnnxPolicy
        except ImportError as exc:
            raise UsageError(f"--controller nn is not available: {exc}") from None
        try:
            return OnnxPolicy(model, preset=config.name, robot=robot)
        except (FileNotFoundError, ValueError) as exc:
            raise UsageError(str(exc)) from None
    raise UsageError(f"unknown controller {kind!r}")


def progress(iterable=None, **kw):
    """A progress bar when writing to a terminal, silent otherwise."""
    from tqdm import tqdm
    return tqdm(iterable, disable=None, dynamic_ncols=True, **kw)
