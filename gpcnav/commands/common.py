"""Options and wiring shared by the subcommands."""
from __future__ import annotations

import argparse
import contextlib
import math
import os
import tempfile
from pathlib import Path

from casadi_gpc.config import DEFAULT_PRESET, PRESETS, preset

from ..errors import MIN_SAMPLE_TIME_S, UsageError, comma_items


MAX_HORIZON = 24
"""The longest horizon the command line takes. The planner's NLP is compiled to C once per
problem, and that compile grows steeply with H: measured on a busy 2-core machine, H = 12
(the improved preset) 10-40 s, H = 24 about 4 min, H = 30 over 15 min; H = 5000 would not
finish building. The presets use 6 and 12 (docs/assumptions.md)."""
MAX_COUNT = 100_000
"""The most episodes one ``--count`` asks for: the scenarios are made before the first
episode runs and every episode's measures are kept until the document is written; 100 000
episodes of the planner are about a core-month."""


def add_preset_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--preset", choices=sorted(PRESETS), default=DEFAULT_PRESET,
                   help=f"planner preset (default {DEFAULT_PRESET})")
    p.add_argument("--sample-time", type=float, default=None, metavar="T",
                   help=f"override the preset's sample time, s (at least {MIN_SAMPLE_TIME_S}; default: the preset's)")
    p.add_argument("--horizon", type=int, default=None, metavar="H",
                   help=f"override the preset's horizon (1 to {MAX_HORIZON}; default: the preset's)")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", dest="planner_set",
                   help="override one of the planner's settings (casadi_gpc.config.PlannerConfig), e.g. "
                        "--set walls_directional_sigma=true, --set clearance_margin_m=0.2, --set beyond_horizon_s=1,2; "
                        "repeatable; the documents record what was changed (planner_changes)")


def with_wall_slots(config, scenarios):
    """``config`` with the NLP's wall slots (:data:`casadi_gpc.config.WALL_SLOTS`) when any
    of ``scenarios`` has walls: a run without walls keeps the NLP it always had."""
    return config.for_walls(any(getattr(s, "walls", ()) for s in scenarios))


def for_run(config, scenarios):
    """``config`` for a run of ``scenarios``: the wall slots where one has walls
    (:func:`with_wall_slots`), the crowd NLP only where one has more movers than the
    preset's slots (:meth:`casadi_gpc.config.PlannerConfig.for_movers`)."""
    movers = max((len(getattr(s, "moving", ())) for s in scenarios), default=0)
    return with_wall_slots(config, scenarios).for_movers(movers)


def planner_config(args):
    cfg = preset(args.preset)
    if args.sample_time is not None and not args.sample_time > 0:
        raise UsageError(f"--sample-time must be positive, got {args.sample_time}")
    if args.sample_time is not None and not args.sample_time >= MIN_SAMPLE_TIME_S:
        raise UsageError(f"--sample-time must be at least {MIN_SAMPLE_TIME_S} s, got {args.sample_time} (one planner "
                         f"decision per sample: a 40 s scenario would take {40 / args.sample_time:.3g} of them)")
    if args.sample_time is not None and not math.isfinite(args.sample_time):
        raise UsageError(f"--sample-time must be finite, got {args.sample_time}")
    if args.horizon is not None and args.horizon < 1:
        raise UsageError(f"--horizon must be at least 1, got {args.horizon}")
    if args.horizon is not None and args.horizon > MAX_HORIZON:
        raise UsageError(f"--horizon must be at most {MAX_HORIZON}, got {args.horizon} (the planner's NLP is compiled "
                         f"to C, and the compile grows steeply with H: about 4 min at H = 24 on a 2-core machine)")
    solver = getattr(args, "solver", None)
    if solver is not None:
        from casadi_gpc.solvers import canonical_name
        try:
            solver = canonical_name(solver)
        except ValueError as exc:
            raise UsageError(f"--solver: {exc}") from None
    cfg = cfg.with_overrides(sample_time_s=args.sample_time, horizon=args.horizon, solver=solver)
    cfg = with_settings(cfg, getattr(args, "planner_set", None) or [])
    # the same bounds for a value given with --set (the dataclass refuses only the impossible)
    if cfg.horizon > MAX_HORIZON:
        raise UsageError(f"--set horizon must be at most {MAX_HORIZON}, got {cfg.horizon} (as --horizon)")
    if cfg.sample_time_s < MIN_SAMPLE_TIME_S:
        raise UsageError(f"--set sample_time_s must be at least {MIN_SAMPLE_TIME_S} s, got {cfg.sample_time_s} "
                         f"(as --sample-time)")
    return cfg


RUN_ADAPTED = ("max_walls", "crowd_moving")
"""Settings a run adapts to its scenarios (:func:`for_run`): not the user's changes."""
SPEED_ONLY = ("solve_lanes",)
"""Settings that change how fast the planner answers, never what it answers (the solve
lanes: :mod:`casadi_gpc.planner.lanes`): a document records them on their own
(``solve_lanes``), not among ``planner_changes``."""


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity where the system says it, as a
    container's limits do; else every core)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def for_pool(config, pool):
    """``config`` with its solve lanes (``PlannerConfig.solve_lanes``, two threads a tick in
    ``improved``) fitted to the worker pool that runs it: a local worker process gets the
    cores the workers leave it, ``usable_cores() // workers`` (at least one), a Ray task the
    one CPU it holds; the preset's (or ``--set``'s) lanes are the most it gets. Two workers
    with two lanes each on a 2-core machine put four busy threads on two cores, and a
    decision's second lane waits for one: with one lane a worker the decision median was up to
    12 % lower in six of eight alternated pairs (level in two), the outcomes the same episode
    for episode (docs/pedestrians.md, "Solve lanes fitted to the workers")."""
    per = 1 if pool.backend == "ray" else max(1, usable_cores() // max(1, pool.workers))
    lanes = max(1, min(config.solve_lanes, per))
    return config if lanes == config.solve_lanes else config.with_overrides(solve_lanes=lanes)


def _setting_value(name: str, text: str, annotation: str):
    """``text`` as a value of the setting ``name`` whose annotation is ``annotation``: true /
    false, none, a number, comma-separated numbers for a tuple, else the text; a value of
    another type than the setting's is a one-line error (a tuple of words: comma-separated
    words)."""
    low = text.strip().lower()
    if low in ("true", "false"):
        value = low == "true"
    elif low == "none":
        value = None
    elif "tuple[str" in annotation:
        value = tuple(comma_items(text, f"--set {name}"))
    elif "tuple" in annotation:
        items = comma_items(text, f"--set {name}")  # (1,,2 was 1,2)
        try:
            value = tuple(float(v) for v in items)
        except ValueError:
            raise UsageError(f"--set {name}: expected comma-separated numbers, got {text!r}") from None
    else:
        try:
            value = int(text) if "int" in annotation and text.strip().lstrip("+-").isdigit() else float(text)
        except ValueError:
            value = text.strip()
    kind = ("None" if value is None else "bool" if isinstance(value, bool) else "tuple" if isinstance(value, tuple)
            else "int" if isinstance(value, int) else "float" if isinstance(value, float) else "str")
    allowed = {"None": "None" in annotation, "bool": "bool" in annotation, "tuple": "tuple" in annotation,
               "int": "int" in annotation or "float" in annotation, "float": "float" in annotation,
               "str": "str" in annotation}
    if not allowed[kind]:
        raise UsageError(f"--set {name}: expected {annotation}, got {text!r}")
    if kind == "int" and "int" not in annotation:
        value = float(value)
    if kind == "float" and not math.isfinite(value):
        raise UsageError(f"--set {name}: must be finite, got {text!r}")
    return value


def _check_names(changes: dict) -> None:
    """The solver and the guesses of ``changes`` checked by name, as ``--solver`` is (the
    solver's alias read as its name); the planner refused a bad one only when it was made, in a
    traceback."""
    try:
        if "solver" in changes:
            from casadi_gpc.solvers import canonical_name
            changes["solver"] = canonical_name(changes["solver"])
        if "guesses" in changes:
            from casadi_gpc.planner.guesses import check_guess_names
            check_guess_names(changes["guesses"])
    except ValueError as exc:  # (each message names its setting)
        raise UsageError(f"--set: {exc}") from None


def with_settings(config, items):
    """``config`` with each ``NAME=VALUE`` of ``items`` (``--set``) applied; an unknown name,
    a value of the wrong type or one the settings refuse is a one-line error."""
    from dataclasses import fields, replace
    known = {f.name: str(f.type) for f in fields(config) if f.name != "name"}
    changes = {}
    for item in items:
        name, eq, text = item.partition("=")
        name = name.strip()
        if not eq or not name:
            raise UsageError(f"--set takes NAME=VALUE, got {item!r}")
        if name not in known:
            raise UsageError(f"--set {name}: not a planner setting (casadi_gpc.config.PlannerConfig)")
        if name in RUN_ADAPTED:
            raise UsageError(f"--set {name}: adapted to each run's scenarios (the wall slots, the crowd NLP), not set here")
        if name in changes:  # (the last one ran, the first said nowhere; --faults refuses it so)
            raise UsageError(f"--set {name}: given twice")
        changes[name] = _setting_value(name, text, known[name])
    if not changes:
        return config
    _check_names(changes)
    try:
        return replace(config, **changes)
    except (ValueError, TypeError) as exc:
        raise UsageError(f"--set: {exc}") from None


NOT_THE_PROBLEM = {"solver", "time_budget_s", *SPEED_ONLY}  # how the NLP is solved, not which NLP it is


def config_differences(a: dict, b: dict) -> list[str]:
    """The planner settings that define the GPC problem and differ between two recorded
    configurations (``PlannerConfig.to_dict``), compared as JSON holds them (a tuple read back
    is a list). A setting one side lacks, recorded before it existed, is taken at its
    default, which is what that code did."""
    import json
    from dataclasses import MISSING, fields

    from casadi_gpc.config import PlannerConfig
    defaults = {f.name: f.default for f in fields(PlannerConfig) if f.default is not MISSING}
    a, b = (json.loads(json.dumps({**defaults, **d}, default=str)) for d in (a, b))
    return sorted(k for k in set(a) | set(b) if k not in NOT_THE_PROBLEM and a.get(k) != b.get(k))


def planner_changes(config) -> dict:
    """The settings of ``config`` that differ from its preset's, less those a run adapts
    (:data:`RUN_ADAPTED`) and those that change only the planner's speed
    (:data:`SPEED_ONLY`): what the documents record as ``planner_changes``."""
    base = PRESETS.get(config.name)
    if base is None:
        return {}
    now, was = config.to_dict(), base.to_dict()
    return {k: v for k, v in now.items() if k not in RUN_ADAPTED + SPEED_ONLY and v != was.get(k)}


def recorded_changes(config, reads: bool = True) -> dict:
    """``{"planner_changes": ...}`` for a document where the run changed the preset's
    settings (:func:`planner_changes`), else nothing; for a controller that does not read
    them (``reads`` False: :func:`gpcnav.controllers.reads_planner_settings`),
    ``{"planner_changes_unused": ...}``: the document says they were given and had no effect."""
    changes = planner_changes(config)
    return {"planner_changes" if reads else "planner_changes_unused": changes} if changes else {}


def refuse_unread_changes(specs, config) -> list:
    """The controllers of ``specs`` that do not read the planner's settings the run changed
    (:func:`planner_changes`): an empty list when nothing was changed or every one reads them.
    When none of them does, a one-line :class:`UsageError` (exit 2): the changes would do
    nothing, and a document recording them would say they had been tested."""
    from ..controllers import reads_planner_settings
    changes = planner_changes(config)
    if not changes:
        return []
    unread = [s for s in specs if not reads_planner_settings(s)]
    if len(unread) == len(specs):
        who = (f"--controller {specs[0].label} does not read" if len(specs) == 1
               else f"none of {', '.join(s.label for s in specs)} reads")
        raise UsageError(f"{', '.join(sorted(changes))}: planner settings (--set, --sample-time, --horizon, --solver), "
                         f"which {who} (a network runs at its model's settings, a peer at its own); "
                         f"drop them, or put the planner on standby with --shield --shield-fallback gpc")
    return unread


def refuse_unused_fallback(args, specs) -> None:
    """A ``--shield-fallback`` that no controller of ``specs`` runs behind (a peer, a baseline or a
    user's class without ``--shield``; ``--no-shield``): one line, exit 2. It was dropped without a
    word, and :func:`refuse_unread_changes` advised it: following the advice gave the same refusal."""
    fallback = getattr(args, "shield_fallback", None)
    if fallback is None or any(s.mode != "off" for s in specs):
        return
    names = ", ".join(s.name for s in specs)
    why = ("--no-shield runs the bare controller" if getattr(args, "shield", None) == "off"
           else f"{names} {'runs' if len(specs) == 1 else 'run'} bare unless --shield is given")
    raise UsageError(f"--shield-fallback {fallback}: what the check layer hands over to, and {why}")


def add_suite_arguments(p: argparse.ArgumentParser) -> None:
    """``--suite NAME --count N --seed S --movers N --behaviour B`` (scenarios.suites)."""
    from scenarios.suites import SUITE_BEHAVIOURS, SUITES
    p.add_argument("--suite", choices=SUITES, default=None,
                   help="a seeded suite instead of files (encounters: the family of the paper's Fig. 7; "
                        "circle-crossing, square-crossing: crowds in CrowdNav's geometry, docs/scenarios.md; "
                        "corridor, doorway, corner: people in buildings, walls; ucy: the people of the UCY recordings, "
                        "docs/pedestrians.md)")
    p.add_argument("--count", type=int, default=None, help=f"episodes of the suite, 1 to {MAX_COUNT} (default: 100)")
    p.add_argument("--seed", type=int, default=None, help="seed of the suite (default: 0)")
    p.add_argument("--movers", type=int, default=None,
                   help="crowd and building suites: how many movers (default 5)")
    p.add_argument("--behaviour", choices=SUITE_BEHAVIOURS, default=None,
                   help="crowd suites: what the movers do (default orca: walkers that avoid each other, "
                        "not the robot); ucy: replay (default: the recorded people, open loop) or orca / "
                        "social_force (walkers that follow their recording and give way to the robot)")


def check_suite_options(suite: str, movers, behaviour) -> None:
    """:func:`scenarios.suites.check_suite_options` as a one-line error naming the option."""
    from scenarios.suites import check_suite_options as check
    try:
        check(suite, movers, behaviour)
    except ValueError as exc:
        raise UsageError(f"--{exc}") from None


def suite_from_args(args):
    """The :class:`scenarios.Suite` the options name (None without ``--suite``); bad values
    are a one-line error."""
    if not getattr(args, "suite", None):
        # options of a suite given with scenario files were ignored without a word
        given = [f"--{n}" for n in ("count", "seed", "movers", "behaviour") if getattr(args, n, None) is not None]
        if given:
            raise UsageError(f"{', '.join(given)}: {'choose' if len(given) > 1 else 'chooses'} a suite's episodes, "
                             f"give {'them' if len(given) > 1 else 'it'} with --suite (scenario files run as they are)")
        return None
    from scenarios import Suite
    args.count = 100 if args.count is None else args.count
    args.seed = 0 if args.seed is None else args.seed
    for name, low in (("count", 1), ("seed", 0), ("movers", 0)):
        if getattr(args, name) is not None and getattr(args, name) < low:
            raise UsageError(f"--{name} must be at least {low}, got {getattr(args, name)}")
    check_suite_options(args.suite, args.movers, args.behaviour)
    if args.count > MAX_COUNT:
        raise UsageError(f"--count must be at most {MAX_COUNT}, got {args.count} (the scenarios are made before the "
                         f"first episode and every episode is kept until the end; split a larger study by --seed)")
    try:
        return Suite(args.suite, args.count, args.seed, 5 if args.movers is None else args.movers, args.behaviour)
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
    p.add_argument("--walls-model", type=Path, default=None, metavar="MODEL.onnx",
                   help="--controller nn: the walls network, which answers where a wall is within 4 m (default: the "
                        "one shipped for --preset, with the shipped model; one trained further by gpcnav train --init)")
    p.add_argument("--crowd-model", type=Path, default=None, metavar="MODEL.onnx",
                   help="--controller nn: the crowd network, which answers where the model cannot hold the obstacles "
                        "in range (default: the one shipped for --preset, with the shipped model)")
    p.add_argument("--shield", dest="shield", action="store_const", const="on", default=None,
                   help="put the controller behind the safety check layer (the default for gpc and nn; "
                        "docs/faults.md)")
    p.add_argument("--no-shield", "--no-safety-filter", dest="shield", action="store_const", const="off",
                   help="run the bare controller, without the safety check layer (default: the controller's own, "
                        "see --shield)")
    p.add_argument("--shield-fallback", "--safety-fallback", choices=("gpc", "brake"), default=None,
                   help="what the check layer hands over to when the controller's answer fails: the GPC on "
                        "standby (gpc; needs CasADi) or the check's own ways out (brake: for nn, the searched way "
                        "out, its default and what a robot without CasADi runs; for the others, the manoeuvres)")
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


FIGURE_OPTIONS = ("plot",)
"""Output options that take a figure: their file's extension must be one matplotlib writes."""
ANIMATION_OPTIONS = ("animate",)
"""Output options that take an animation: a GIF (``.gif``), the one format written."""


def check_output_files(inputs=(), models=(), **paths) -> None:
    """Refuse in one line (exit 2), before any work, an output file (option name -> path or
    None) that could not be written: a path that is a folder, or whose folder cannot be made
    or written in (``/proc/x.png``); one of the ``inputs`` (the scenario files: it would be
    overwritten) or of the ``models`` (``--model``: ``--out M.onnx`` wrote RUN.json over the model
    it ran, until 2026-12-02), or the same file as another output; a figure whose extension matplotlib does
    not write (``--plot r.txt`` failed after the whole run), an animation that is not a
    ``.gif``. Nothing is left behind: a missing folder is made when the file is written."""
    given = {option: Path(path) for option, path in paths.items() if path is not None}
    ins = [(Path(i), "scenario file") for i in inputs if i] + [(Path(m), "model file") for m in models if m]
    seen: dict[Path, str] = {}
    for option, path in given.items():
        what = f"--{option.replace('_', '-')} {path}"
        check_name_lengths(path, what)
        if path.is_dir():
            raise UsageError(f"{what} is a folder, not a file")
        check_regular_file(path, what)
        for i, kind in ins:
            if same_file(path, i):
                raise UsageError(f"{what} is the {kind} {i}: it would be overwritten")
        key = path.resolve()
        if key in seen:
            raise UsageError(f"{what} is also given to --{seen[key].replace('_', '-')}: one file for two outputs")
        seen[key] = option
        if option in FIGURE_OPTIONS:
            check_figure_path(path, what)
        if option in ANIMATION_OPTIONS and path.suffix.lower() != ".gif":
            raise UsageError(f"{what}: an animation is written as a GIF; name it .gif")
        check_writable_folder(path.parent, f"{what}: its folder {path.parent}")


def check_name_lengths(path: Path, what: str) -> None:
    """Refuse in one line a path with a name longer than a file system takes (255 bytes): the
    checks asked the file system about it and raised its OSError, a traceback (until 2026-12-01)."""
    from casadi_gpc.io import NAME_MAX
    for part in Path(path).parts:
        if len(part.encode()) > NAME_MAX:
            raise UsageError(f"{what}: the name {part[:20]}... is {len(part.encode())} bytes long, more than the "
                             f"{NAME_MAX} a file system takes")


def check_regular_file(path: Path, what: str) -> None:
    """Refuse in one line an output that exists and is not a regular file, or is a link to
    one that is not (a device, a pipe: ``/dev/null``, ``/dev/stdout``). Every output is
    written whole, to a temporary file renamed over the path, so the rename replaced the
    device or the link itself (``--out /dev/full`` as root replaced the device node with the
    model file, exit 0)."""
    if path.exists() and not path.is_file():
        raise UsageError(f"{what} is not a regular file (a device, a pipe, or a link to one): outputs are written "
                         f"whole to a temporary file renamed over the path, which would replace it")


def check_figure_path(path: Path, what: str) -> None:
    """Refuse a figure whose extension matplotlib does not write, naming those it does."""
    from matplotlib.backend_bases import FigureCanvasBase
    formats = FigureCanvasBase.get_supported_filetypes()
    ext = path.suffix.lower().lstrip(".")
    if ext not in formats:
        said = f"does not write .{ext} figures" if ext else "takes a figure's format from its extension, and it has none"
        raise UsageError(f"{what}: matplotlib {said} (it writes {', '.join('.' + f for f in sorted(formats))})")


def same_file(a: Path, b: Path) -> bool:
    """Whether ``a`` and ``b`` name the same file (``b`` exists; ``a`` may not yet)."""
    try:
        return a.exists() and os.path.samefile(a, b)
    except OSError:
        return a.resolve() == b.resolve()


def check_writable_folder(folder: Path, what: str) -> None:
    """Refuse in one line a folder that cannot be made or written in: its nearest existing
    ancestor must be a folder where a file can be made (tried, and removed at once: write
    permission bits do not tell for ``/proc`` or a read-only mount, nor for root)."""
    probe = Path(folder)
    while not probe.exists() and probe.parent != probe:
        probe = probe.parent
    if not probe.is_dir():
        raise UsageError(f"{what}: {probe} exists and is not a folder")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".gpcnav-write-check-", dir=probe)
    except OSError as exc:
        raise UsageError(f"{what}: cannot write files in {probe} ({exc.strerror or exc})") from None
    os.close(fd)
    os.unlink(tmp)


@contextlib.contextmanager
def connected(pool):
    """``pool.connected()`` (:meth:`casadi_gpc.pool.WorkerPool.connected`: Ray reached or
    started now, shut down on leaving) with an absent cluster as a one-line
    :class:`UsageError`."""
    from casadi_gpc.pool import ClusterUnavailable
    with contextlib.ExitStack() as stack:
        try:
            stack.enter_context(pool.connected())
        except ClusterUnavailable as exc:
            raise UsageError(str(exc)) from None
        yield pool


def _make_folder(folder: Path, what: str) -> None:
    check_name_lengths(folder, what)
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
