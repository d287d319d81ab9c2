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
    solver = getattr(args, "solver", None)
    if solver is not None:
        from casadi_gpc.solvers import canonical_name
        try:
            solver = canonical_name(solver)
        except ValueError as exc:
            raise UsageError(f"--solver: {exc}") from None
    return cfg.with_overrides(sample_time_s=args.sample_time, horizon=args.horizon, solver=solver)


def add_suite_arguments(p: argparse.ArgumentParser) -> None:
    """``--suite NAME --count N --seed S --movers N --behaviour B`` (scenarios.suites)."""
    from scenarios.suites import SUITE_BEHAVIOURS, SUITES
    p.add_argument("--suite", choices=SUITES, default=None,
                   help="a seeded suite instead of files (encounters: the family of the paper's Fig. 7; "
                        "circle-crossing, square-crossing: crowds in CrowdNav's geometry, docs/scenarios.md; "
                        "ucy: the people of the UCY recordings, docs/pedestrians.md)")
    p.add_argument("--count", type=int, default=100, help="episodes of the suite")
    p.add_argument("--seed", type=int, default=0, help="seed of the suite")
    p.add_argument("--movers", type=int, default=5, help="crowd suites: how many movers (default 5)")
    p.add_argument("--behaviour", choices=SUITE_BEHAVIOURS, default=None,
                   help="crowd suites: what the movers do (default orca: walkers that avoid each other, "
                        "not the robot); ucy: replay (default: the recorded people, open loop) or orca / "
                        "social_force (walkers that follow their recording and give way to the robot)")


def suite_from_args(args):
    """The :class:`scenarios.Suite` the options name (None without ``--suite``); bad values
    are a one-line error."""
    if not getattr(args, "suite", None):
        return None
    from scenarios import Suite
    for name, low in (("count", 1), ("seed", 0), ("movers", 0)):
        if getattr(args, name) < low:
            raise UsageError(f"--{name} must be at least {low}, got {getattr(args, name)}")
    try:
        return Suite(args.suite, args.count, args.seed, args.movers, args.behaviour)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def add_controller_arguments(p: argparse.ArgumentParser, many: bool = False) -> None:
    """``--controller NAME`` (``--controllers LIST`` with ``many``), the check layer's and the
    network's options, and the preset's. Names are those of :mod:`gpcnav.controllers`."""
    names = ("gpc, nn, orca, hrvo, social_force, mppi, the baselines stand and blind, or MODULE:CLASS "
             "(a class of yours, README)")
    if many:
        p.add_argument("--controllers", default="gpc,nn", metavar="LIST",
                       help=f"comma-separated controllers: {names}; default gpc,nn")
    else:
        p.add_argument("--controller", default="gpc", metavar="NAME", help=f"{names}; default gpc")
    p.add_argument("--model", type=Path, default=None,
                   help="ONNX model for --controller nn (default: the one shipped for --preset)")
    p.add_argument("--shield", dest="shield", action="store_const", const="on", default=None,
                   help="put the controller behind the safety check layer (the default for gpc and nn; "
                        "docs/faults.md)")
    p.add_argument("--no-shield", "--no-safety-filter", dest="shield", action="store_const", const="off",
                   help="run the bare controller, without the safety check layer")
    p.add_argument("--shield-fallback", "--safety-fallback", choices=("gpc", "brake"), default=None,
                   help="what the check layer hands over to when the controller's answer fails: the GPC on "
                        "standby (the default for nn) or only its braking/turning manoeuvres (brake)")
    p.add_argument("--passes", type=int, choices=(1, 2), default=None,
                   help="--controller nn: one pass or the paper's two passes (default: what the model file "
                        "says, docs/nn.md)")
    p.add_argument("--solver", default=None, metavar="NAME",
                   help="--controller gpc: the NLP solver (default: the preset's; see docs/solvers.md)")
    add_preset_arguments(p)


def check_seed(seed: int | None) -> None:
    """Refuse a negative ``--seed`` in one line (numpy's generators take none)."""
    if seed is not None and seed < 0:
        raise UsageError(f"--seed must be 0 or more, got {seed}")


def make_output_folder(path: Path, option: str) -> None:
    """Make the folder ``path`` (and its parents), or refuse in one line (exit 2): before
    any work, so that nothing is computed for nowhere to go."""
    _make_folder(path, f"{option} {path}")


def check_output_files(**paths) -> None:
    """Make the folder of each output file given (option name -> path or None), or refuse
    in one line (exit 2); a path that is a folder is refused too."""
    for option, path in paths.items():
        if path is None:
            continue
        what = f"--{option.replace('_', '-')} {path}"
        if path.is_dir():
            raise UsageError(f"{what} is a folder, not a file")
        _make_folder(path.parent, f"{what}: its folder {path.parent}")


def _make_folder(folder: Path, what: str) -> None:
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"{what} exists and is not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{what} cannot be made ({exc.strerror or exc})") from None


def progress(iterable=None, **kw):
    """A progress bar when writing to a terminal, silent otherwise."""
    from tqdm import tqdm
    return tqdm(iterable, disable=None, dynamic_ncols=True, **kw)
