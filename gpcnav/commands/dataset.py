"""Label random driving situations with the GPC into a dataset directory (shards and
manifest.json); resumable after any interruption: run it again with the same arguments.

With --dagger MODEL the command instead appends one round of on-policy data to an existing
dataset: it runs the network MODEL on --episodes random episodes and labels every situation
it visits with the GPC (DAgger). By default the network drives bare (--dagger-safety off), so
the states it fails in are the ones labelled; --dagger-safety gpc|brake runs it behind the
safety filter instead. With --dagger gpc the GPC itself drives (part ``gpc<R>``): the states
of the closed-loop distribution the network has to imitate, labelled the same way. With
--dagger-files the episodes are scenario files of your own (navground's scenes exported by
tools/export_navground_scenario.py, say) in place of a suite."""
from __future__ import annotations

import os
import sys
from pathlib import Path

from scenarios import CROWD_SUITES, SUITES
from scenarios.suites import SUITE_BEHAVIOURS

from ..errors import UsageError
from .common import (add_preset_arguments, check_name_lengths, check_seed, check_suite_options, check_writable_folder,
                     config_differences, connected, planner_config, progress, usable_cores)

MAX_SAMPLES = 100_000_000
"""The most samples one ``--samples`` asks for: labelling runs at 100-1000 samples/s on a
2-core machine (docs/solvers.md), so 10^8 samples are days to weeks of it, and tens of GB of
shards (docs/evaluation.md)."""


def add_arguments(p):
    p.add_argument("--out", type=Path, required=True, help="dataset directory (created, or resumed)")
    p.add_argument("--samples", type=int, default=None,
                   help="labelled samples wanted, mirror samples included (required unless --dagger)")
    p.add_argument("--workers", type=int, default=usable_cores(), help="worker processes (default: one a core)")
    p.add_argument("--backend", choices=("local", "ray"), default="local",
                   help="local worker processes (default) or a Ray cluster")
    p.add_argument("--address", default=None,
                   help="address of an existing Ray cluster (--backend ray; default: start a local one)")
    p.add_argument("--seed", type=int, default=0, help="seed of the situations (default 0)")
    add_preset_arguments(p)
    p.add_argument("--layout", choices=("paper", "multi", "set", "set-walls"), default=None,
                   help="feature layout of a new dataset: the paper's (one moving obstacle; the default), multi (3 "
                        "moving + 3 static), set (12 moving + 6 static as one set, for the set network) or set-walls "
                        "(set, and the walls as a 24-sector scan; labelled by the planner with wall slots); a "
                        "--dagger round labels in its dataset's layout")
    p.add_argument("--robot", type=Path, default=None, metavar="SCENARIO.toml",
                   help="label for the robot of this scenario file (its [robot]: wheel base, radius, wheel limits), "
                        "for a network that drives it (default: the contract's robot, 0.5 m wheel base, 0.35 m, "
                        "0.8 m/s, 0.8 m/s^2); a --dagger round labels for its dataset's robot")
    p.add_argument("--shard-size", type=int, default=None,
                   help="samples per shard of a new dataset (even; default 1000); a --dagger round appends one shard")
    p.add_argument("--no-mirror", action="store_true", help="do not add the mirror image of each situation")
    p.add_argument("--mirror-check-every", type=int, default=25, metavar="K",
                   help="solve the mirrored situation for every K-th situation as a check of the labels (0: never)")
    p.add_argument("--scheme", choices=("sampled", "two-pass"), default="sampled",
                   help="sampled situations (default), or the paper's two passes: tracking situations without "
                        "obstacles (pass 1) and the robot on its predicted path with an obstacle (pass 2); "
                        "nn_export/training/two_pass.py")
    p.add_argument("--tie-margin", type=float, default=None, metavar="REL",
                   help="near ties: label the pass on the right where it costs at most REL (relative) more "
                        "than the pass on the left (default: the planner's own choice; "
                        "nn_export/training/ties.py)")
    p.add_argument("--solver", default=None,
                   help="the planner's NLP solver for labelling (default: the one measured fastest for "
                        "labels under the preset, nn_export.training.labels.LABEL_SOLVERS)")
    p.add_argument("--dagger", type=Path, default=None, metavar="MODEL.onnx|gpc",
                   help="append one round of on-policy data from this network (or, with the word gpc, from "
                        "the GPC itself) to the dataset at --out")
    p.add_argument("--dagger-safety", choices=("off", "gpc", "brake"), default="off",
                   help="--dagger MODEL: run the network bare (off, default: its own failure states get "
                        "labelled) or behind the safety check layer with the GPC (gpc) or only its manoeuvres "
                        "(brake) as fallback; --dagger gpc: the planner drives behind its check layer")
    p.add_argument("--labels", choices=("cold", "closed-loop"), default="cold",
                   help="--dagger: label each visited situation by the GPC solved afresh from its fixed guesses "
                        "(cold, default) or by a GPC kept in step with the episode, as it commands in closed loop "
                        "(closed-loop; nn_export/training/dataset/onpolicy.py)")
    p.add_argument("--episodes", "--count", dest="episodes", type=int, default=None,
                   help="episodes of the suite for --dagger (default 100; with --dagger-files, one a file)")
    p.add_argument("--round", type=int, default=None,
                   help="--dagger: the round's number (names the part: dagger<R>, gpc<R>; default 1)")
    p.add_argument("--dagger-noise", type=float, default=0.0, metavar="SIGMA",
                   help="--dagger: add N(0, SIGMA) m/s to each wheel speed the driver applies (DART: the "
                        "GPC drives, the states spread as a learner's errors would spread them; labels "
                        "are unaffected); default 0")
    p.add_argument("--dagger-suite", "--suite", dest="dagger_suite", choices=SUITES, default=None,
                   help="--dagger: the episodes' suite (default: random, or random-multi for the multi and set "
                        "layouts; encounters: the family of the paper's Fig. 7; the crowd and building suites take "
                        "--movers and --behaviour, ucy --behaviour); its seed is --seed plus 1000 times --round "
                        "(plus 500 where the GPC drives), so that rounds never repeat each other")
    p.add_argument("--dagger-files", type=Path, nargs="+", default=None, metavar="SCENARIO.toml",
                   help="--dagger: drive these scenario files instead of a suite (one episode each; e.g. "
                        "navground's scenes exported by tools/export_navground_scenario.py, or your own)")
    p.add_argument("--movers", type=int, default=None,
                   help="--dagger on a crowd or building suite: walkers per scene (default 5)")
    p.add_argument("--behaviour", choices=SUITE_BEHAVIOURS, default=None,
                   help="--dagger on a crowd or building suite: how the walkers move (default orca); ucy: replay "
                        "(default) or orca / social_force")
    p.add_argument("--start-offset", type=float, default=0.0, metavar="M",
                   help="--dagger: start each episode's robot U(-M, M) m beside the path, turned by "
                        "U(-M/2, M/2) rad (recovering starts, as in Fig. 7.3); default 0")


def _layout_and_config(args):
    from nn_export.runtime.layouts import layout_for
    config = planner_config(args)
    layout = layout_for(args.layout, config.horizon)
    return config.for_walls(bool(layout.wall_sectors)), layout


def _note_timing(config) -> None:
    """Say, before any labelling, that labels at another horizon or sample time than the preset's
    make no network gpcnav runs: ``train`` refuses such a dataset (its preset differs) and such a
    network (every command would refuse it). Labelled anyway: the solutions are data of their own."""
    from casadi_gpc.config import preset
    from nn_export.runtime.model_file import timing_mismatch
    if timing_mismatch(config.name, config.horizon, config.sample_time_s):
        base = preset(config.name)
        print(f"gpcnav dataset: note: labels at H={config.horizon}, T={config.sample_time_s:g} s, where preset "
              f"{config.name!r} has H={base.horizon}, T={base.sample_time_s:g} s: gpcnav train refuses them (a "
              f"policy runs a network at its preset's horizon and sample time); labelled for use elsewhere",
              file=sys.stderr)


def run(args) -> int:
    from nn_export.training.dataset import DatasetMismatch, DatasetSpec, generate
    from nn_export.training.labels import label_solver
    if args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    check_seed(args.seed)
    if args.address and args.backend != "ray":
        raise UsageError("--address needs --backend ray")
    if not (0.0 <= args.dagger_noise <= 0.8):
        raise UsageError(f"--dagger-noise must be in [0, 0.8] m/s, got {args.dagger_noise}")
    if not (0.0 <= args.start_offset <= 3.0):
        raise UsageError(f"--start-offset must be in [0, 3] m, got {args.start_offset}")
    if args.tie_margin is not None and not 0.0 <= args.tie_margin < 1.0:
        raise UsageError(f"--tie-margin must be in [0, 1), got {args.tie_margin}")
    if args.dagger is not None and args.scheme != "sampled":
        raise UsageError("--scheme applies to sampled situations, not to --dagger rounds")
    # (--round and --dagger-safety were taken and ignored without --dagger)
    if args.dagger is None and (args.dagger_noise or args.start_offset or args.dagger_suite or args.dagger_files
                                or args.labels != "cold" or args.round is not None or args.dagger_safety != "off"):
        raise UsageError("--round, --dagger-safety, --dagger-noise, --dagger-suite, --dagger-files, --start-offset "
                         "and --labels apply to on-policy rounds: they need --dagger")
    if args.dagger is not None and args.samples is not None:  # (it was taken and ignored)
        raise UsageError("--samples: a --dagger round adds the samples its episodes visit (--episodes, or "
                         "--dagger-files), not a number asked")
    if str(args.dagger) == "gpc" and args.dagger_safety != "off":  # (it was taken and ignored)
        raise UsageError("--dagger-safety is for --dagger MODEL.onnx: with --dagger gpc the planner drives behind "
                         "its own check layer")
    args.round = 1 if args.round is None else args.round
    if args.dagger_files and args.dagger_suite:
        raise UsageError("give --dagger-suite or --dagger-files, not both")
    if args.dagger_files and args.episodes is not None:
        raise UsageError("--dagger-files runs one episode a file: --episodes does not apply")
    if args.dagger is None and (args.movers is not None or args.behaviour is not None or args.episodes is not None):
        raise UsageError("--episodes, --movers and --behaviour choose an on-policy round's episodes: they need --dagger")
    if args.dagger_files and (args.movers is not None or args.behaviour is not None):
        raise UsageError("--movers and --behaviour choose a suite's walkers: --dagger-files runs the files as they are")
    if args.dagger is not None and not args.dagger_files:  # (the default suites, random and random-multi, take neither)
        check_suite_options(args.dagger_suite or "random", args.movers, args.behaviour)
    if args.labels == "closed-loop" and args.tie_margin is not None:
        raise UsageError("--tie-margin applies to cold labels, not --labels closed-loop")
    if args.dagger is not None:
        if args.robot is not None:
            raise UsageError("--robot applies to a new dataset: a --dagger round labels for its dataset's robot")
        given = [o for o, v in (("--layout", args.layout), ("--shard-size", args.shard_size)) if v is not None]
        if given:  # (both were taken and ignored)
            raise UsageError(f"{' and '.join(given)} appl{'y' if len(given) > 1 else 'ies'} to a new dataset: a "
                             f"--dagger round labels in its dataset's layout and appends its samples as one shard")
        return _dagger(args)
    args.layout = "paper" if args.layout is None else args.layout
    args.shard_size = 1000 if args.shard_size is None else args.shard_size
    if args.samples is None:
        raise UsageError("--samples is required")
    if args.samples < 1:
        raise UsageError(f"--samples must be at least 1, got {args.samples}")
    if args.samples > MAX_SAMPLES:
        raise UsageError(f"--samples must be at most {MAX_SAMPLES}, got {args.samples} (labelling runs at 100-1000 "
                         f"samples/s on a 2-core machine: {args.samples / 1000 / 86400:.3g} days at best there)")
    if args.shard_size < 2 or args.shard_size % 2 or args.shard_size > 1_000_000:
        raise UsageError(f"--shard-size must be an even number from 2 to 1000000, got {args.shard_size}")
    if args.mirror_check_every < 0:
        raise UsageError(f"--mirror-check-every must be 0 or more, got {args.mirror_check_every}")
    check_name_lengths(args.out, f"--out {args.out}")
    if args.out.exists() and not args.out.is_dir():
        raise UsageError(f"--out {args.out} exists and is not a directory")
    check_writable_folder(args.out, f"--out {args.out}")  # (/proc: its lock file's traceback until 2026-12-01)
    if args.backend == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise UsageError("--backend ray needs Ray: pip install 'gpcnav[distributed]'") from None
    from casadi_gpc.pool import WorkerPool
    config, layout = _layout_and_config(args)
    _note_timing(config)
    if args.scheme == "two-pass" and layout.name != "paper":
        raise UsageError("--scheme two-pass needs --layout paper (one moving obstacle)")
    robot = _robot(args.robot)
    spec = DatasetSpec(samples=args.samples, config=config, layout=layout, seed=args.seed, robot=robot,
                       solver=args.solver or label_solver(config), shard_size=args.shard_size,
                       mirror=not args.no_mirror, mirror_check_every=args.mirror_check_every,
                       scheme=args.scheme, tie_margin=args.tie_margin, sampler=_sampler(args.scheme, robot))
    with connected(WorkerPool(args.workers, args.backend, args.address)):  # an absent cluster: before any folder
        _check_solver(spec)
        try:
            args.out.mkdir(parents=True, exist_ok=True)
            if not os.access(args.out, os.W_OK):
                raise PermissionError(13, "not writable")
        except OSError as exc:
            raise UsageError(f"--out {args.out}: cannot write there ({exc.strerror or exc})") from None

        def log(msg):
            print(f"gpcnav dataset: {msg}", file=sys.stderr)

        try:
            man = generate(args.out, spec, args.workers, args.backend, args.address,
                           progress=lambda **kw: progress(desc="labelling", **kw), log=log)
        except DatasetMismatch as exc:
            raise UsageError(str(exc)) from None
    part = man["parts"]["offpolicy"]
    last, st = part["last_run"], part["stats"]
    rate = f"{last['samples_per_s']:.0f} samples/s" if last["samples_per_s"] else "nothing left to do"
    print(f"{args.out}: {man['samples']} samples in {len(man['shards'])} shards "
          f"(this run: {last['samples_done']} samples in {last['elapsed_s']:.1f} s, {rate}, "
          f"{last['workers']} {last['backend']} workers); layout {layout.name} v{layout.version} "
          f"({layout.size} features), preset {config.name}, solver {spec.solver}; "
          f"{st['not_converged']} of {st['situations']} situations not converged "
          f"({st['answered_by_fallback_solver']} answered by the fallback solver); mirror check: "
          f"{st['mirror_checked']} checked, max diff {st['mirror_max_diff_mps']:.1e} m/s, "
          f"{st['mirror_over_tolerance']} over {st['mirror_tolerance_mps']:.0e}")
    return 0


def _sampler(scheme: str, robot):
    """The sampler's settings of a scheme (the two-pass scheme has its own) for ``robot``
    (:meth:`~nn_export.training.sampler_settings.SamplerSettings.for_robot`)."""
    if scheme == "two-pass":
        from nn_export.training.two_pass import SETTINGS
        return SETTINGS.for_robot(robot)
    from nn_export.training.sampler_settings import SamplerSettings
    return SamplerSettings().for_robot(robot)


def _robot(path: Path | None):
    """The robot of the scenario file ``path`` (a bad file: its one-line ScenarioError), or the
    contract's default robot."""
    from casadi_gpc.robot import RobotParams
    if path is None:
        return RobotParams()
    from scenarios import load_scenario
    return load_scenario(path).robot


def _check_solver(spec) -> None:
    """Refuse an unknown solver name before any work (one line)."""
    from nn_export.training.dataset import prepare_labeller
    try:
        prepare_labeller(spec)  # local workers are forked afterwards and inherit the built solver
    except (ValueError, RuntimeError) as exc:
        raise UsageError(f"--solver {spec.solver}: {str(exc).splitlines()[0]}") from None


def _dagger(args) -> int:
    """One DAgger round: the network drives, the GPC labels what it sees."""
    from casadi_gpc.pool import WorkerPool
    from casadi_gpc.robot import RobotParams
    from nn_export.training.dataset import (
        PART_STRIDE, DatasetMismatch, OnPolicyOptions, append_part, collect_on_policy_parallel,
    )
    from nn_export.runtime.layouts import layout_from_dict
    from nn_export.training.labels import label_solver
    man = _dagger_manifest(args)
    config = planner_config(args)
    if man.get("preset") != config.name:
        raise UsageError(f"{args.out} was labelled under preset {man.get('preset')!r}, not {config.name!r}")
    by_gpc = str(args.dagger) == "gpc"
    part = f"{'gpc' if by_gpc else 'dagger'}{args.round}"
    if part in man.get("parts", {}):
        raise UsageError(f"{args.out} already has a part {part} (round {args.round})")
    layout = layout_from_dict(man["feature_layout"])
    # a layout that reads walls is labelled (and its GPC rounds driven) by the planner with wall slots
    config = config.for_walls(bool(layout.wall_sectors))
    differ = config_differences(man.get("planner_config") or {}, config.to_dict())
    if differ:
        verb = "differ" if len(differ) > 1 else "differs"
        raise UsageError(f"{args.out} was labelled with other planner settings ({', '.join(differ)} {verb}): "
                         f"a round appended must be labelled as the rest")
    try:
        robot = RobotParams(**man["robot"]) if "robot" in man else RobotParams()
    except TypeError:
        raise UsageError(f"{args.out}/manifest.json: its robot {man['robot']!r} is not a robot's fields") from None
    if robot != RobotParams() and not args.dagger_files:
        raise UsageError(f"{args.out} was labelled for another robot than the suites drive ({robot.to_dict()}): "
                         f"give --dagger-files, scenario files of that robot")
    factory = _driver(args, config, robot, by_gpc)
    solver = args.solver or label_solver(config)
    _check_solver_for(config, layout, solver)
    suite = args.dagger_suite or ("random-multi" if layout.name in ("multi", "set", "set-walls") else "random")
    # episodes never repeat the evaluation suite (seed 1) nor each other (GPC parts: +500)
    suite_seed = args.seed + 1000 * args.round + (500 if by_gpc else 0)
    if args.movers is not None and args.movers < 0:
        raise UsageError(f"--movers must not be negative, got {args.movers}")
    movers = 5 if args.movers is None else args.movers
    if args.dagger_files:
        scenarios = _dagger_files(args.dagger_files, suite_seed, args.start_offset, robot)
        suite, episodes = "files", len(scenarios)
    else:
        episodes = 100 if args.episodes is None else args.episodes
        try:
            scenarios = _dagger_scenarios(suite, episodes, suite_seed, args.start_offset, movers, args.behaviour)
        except ValueError as exc:  # e.g. more walkers than the geometry can place
            raise UsageError(f"--suite {suite}: {exc}") from None
    _check_walls_readable(scenarios, layout, args.dagger_files, suite)
    options = OnPolicyOptions(config, layout, solver, robot,
                              mirror=not args.no_mirror, mirror_check_every=args.mirror_check_every,
                              noise_mps=args.dagger_noise, id_base=(args.round + (500 if by_gpc else 0)) * PART_STRIDE,
                              tie_margin=args.tie_margin, labels=args.labels)
    pool = WorkerPool(args.workers, args.backend, args.address)
    with connected(pool):
        arrays, stats = collect_on_policy_parallel(factory, scenarios, options, pool,
                                                   progress=lambda **kw: progress(desc=f"{part}", **kw))
    crowd = {"movers": movers, "behaviour": _behaviour(suite, args.behaviour)} if suite in CROWD_SUITES else {}
    if args.dagger_files:
        crowd = {"files": [sc.name for sc in scenarios]}
    info = {"round": args.round, "model": str(args.dagger), "suite": suite, **crowd, "episodes": episodes,
            "suite_seed": suite_seed, "solver": solver, "safety_filter": None if by_gpc else args.dagger_safety,
            "driving_noise_mps": args.dagger_noise, "start_offset_m": args.start_offset, "tie_margin": args.tie_margin,
            "labels": args.labels,
            "noise_applied": int(sum(e.get("noise_applied", 0) for e in stats["episodes"]))}
    try:
        doc = append_part(args.out, part, arrays, stats, info)
    except DatasetMismatch as exc:
        raise UsageError(str(exc)) from None
    outcomes = {}
    for e in stats["episodes"]:
        outcomes[e["outcome"]] = outcomes.get(e["outcome"], 0) + 1
    print(f"{args.out}: {part} added {len(arrays['labels'])} samples "
          f"({stats['situations']} situations, {stats['not_converged']} not converged) from {episodes} "
          f"episodes of {suite} ({', '.join(f'{k} {v}' for k, v in sorted(outcomes.items()))}); "
          f"dataset now {doc['samples']} samples")
    return 0


def _check_walls_readable(scenarios, layout, files, suite: str) -> None:
    """Refuse, before any work, episodes with walls for a dataset whose layout does not read
    them: its labels are planned without wall slots, and the first situation with walls
    stopped the round with a ValueError traceback (``--dagger-files`` with ``[[walls]]``,
    ``--dagger-suite corridor``)."""
    if layout.wall_sectors:
        return
    for k, sc in enumerate(scenarios):
        if getattr(sc, "walls", ()):
            where = f"{files[k]}: has walls" if files else f"--suite {suite}: its episodes have walls"
            raise UsageError(f"{where}, and the dataset's layout {layout.name!r} does not read walls (its labels are "
                             f"planned without them): a round with walls goes to a dataset of --layout set-walls")


def _dagger_manifest(args) -> dict:
    """The manifest of the dataset a round appends to, after checking the round's numbers."""
    from nn_export.training.dataset import read_manifest
    if not (args.out / "manifest.json").is_file():
        raise UsageError(f"--dagger appends to an existing dataset, and {args.out} has no manifest.json")
    if args.episodes is not None and args.episodes < 1:
        raise UsageError(f"--episodes must be at least 1, got {args.episodes}")
    if args.round < 1:
        raise UsageError(f"--round must be at least 1, got {args.round}")
    try:
        man = read_manifest(args.out)
        if not isinstance(man.get("parts"), dict) or "feature_layout" not in man:
            raise ValueError("not a manifest")
    except (ValueError, AttributeError, OSError):
        raise UsageError(f"{args.out}/manifest.json is damaged: run `gpcnav dataset --out {args.out}` with the "
                         f"arguments that made it to rebuild it from its shards, then the round again") from None
    return man


def _driver(args, config, robot, by_gpc: bool):
    """A picklable factory of the round's driver: the GPC, or the network (refused now, in
    one line, if its model is bad)."""
    import functools

    from ..controllers import make_controller
    if by_gpc:
        return functools.partial(make_controller, "gpc", config, robot)
    factory = functools.partial(make_controller, "nn", config, robot, args.dagger, args.dagger_safety)
    factory()  # refuse a bad model before any work (one line)
    return factory


def _check_solver_for(config, layout, solver: str) -> None:
    """Refuse an unknown labelling solver before any work (one line)."""
    from nn_export.training.dataset import DatasetSpec
    _check_solver(DatasetSpec(1, config, layout, solver=solver))


def _dagger_files(paths, suite_seed: int, start_offset_m: float, robot=None) -> list:
    """The round's episodes from scenario files (each read and checked before any work; a bad
    one is a one-line error naming it), their starts moved as :func:`_dagger_scenarios` moves
    a suite's. A file whose ``[robot]`` is not ``robot``, the one the dataset is labelled for
    and its driver made for, is refused in one line naming it: its episode would move another
    robot than the one the labels plan (before 2026-11-30 it was driven and labelled, silently)."""
    from scenarios import load_scenario
    scenarios = [load_scenario(p) for p in paths]
    if robot is not None:
        mine = robot.to_dict()
        for path, sc in zip(paths, scenarios):
            theirs = sc.robot.to_dict()
            differ = [k for k in mine if theirs[k] != mine[k]]
            if differ:
                raise UsageError(f"{path}: its robot is not the one the dataset is labelled for ("
                                 + ", ".join(f"{k} {theirs[k]:g} vs {mine[k]:g}" for k in differ)
                                 + "): a round drives and labels that robot only")
    return _offset(scenarios, suite_seed, start_offset_m)


def _behaviour(suite: str, behaviour: str | None) -> str:
    """The walkers' behaviour a suite runs with (``behaviour``, else the suite's default)."""
    from scenarios.suites import default_behaviour
    return default_behaviour(suite) if behaviour is None else behaviour


def _dagger_scenarios(suite: str, episodes: int, suite_seed: int, start_offset_m: float, movers: int = 5,
                      behaviour: str | None = None) -> list:
    """The round's episodes, their starts moved up to ``start_offset_m`` beside the path."""
    from scenarios import Suite
    return _offset(Suite(suite, episodes, suite_seed, movers, behaviour).scenarios(), suite_seed, start_offset_m)


def _offset(scenarios: list, suite_seed: int, start_offset_m: float) -> list:
    """``scenarios`` with their robot's start moved up to ``start_offset_m`` beside the path."""
    if start_offset_m > 0:
        import numpy as np

        from nn_export.training.dataset import perturb_start
        rng = np.random.default_rng([suite_seed, 77])
        scenarios = [perturb_start(sc, rng, start_offset_m, start_offset_m / 2) for sc in scenarios]
    return scenarios
