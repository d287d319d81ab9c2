"""The one controller registry: every controller a command can run, by name.

``simulate``, ``evaluate``, ``compare``, ``bench`` and the Gymnasium environment make their
controllers here, so a name means the same thing everywhere:

========================  =============================================================
``gpc``                   the GPC planner (:class:`casadi_gpc.planner.gpc.GPCController`)
``nn``                    the network (:class:`nn_export.OnnxPolicy`) behind the
                          planner-free check, as a robot deploys it (``--shield-fallback
                          gpc``: the GPC on standby behind it)
``orca``, ``hrvo``,       navground's behaviours with its differential-drive kinematics
``social_force``          (:mod:`gpcnav.peers.navground_peer`)
``mppi``                  pytorch-mppi on the GPC's cost (:mod:`gpcnav.peers.mppi_peer`;
                          needs torch, the ``train`` extra)
``stand``, ``blind``      baselines: a robot that stands still, one that drives its
                          reference blind (:mod:`gpcnav.peers.baselines`)
``MODULE:CLASS``          any importable class made with no arguments that answers the
                          Policy protocol (``reset()``, ``decide(observation)``,
                          ``sample_time_s``)
========================  =============================================================

A name that cannot be made is a :class:`~gpcnav.errors.UsageError` (one line, exit 2),
raised by :func:`check` before any work. Any of them runs behind the controller-agnostic
check layer (:class:`casadi_gpc.safety.Shield`) as the shield mode says (``--shield``,
``--no-shield``, ``--shield-fallback``; :data:`SHIELD_MODES`): by default ``gpc`` and ``nn``
do (``nn`` with no planner on standby: what a robot without CasADi runs), the peers and a user's class run bare, as their users run them. What the check layer
trusts from each controller and what it falls back on is declared here, next to its name
(:data:`REGISTRY`: one :class:`~casadi_gpc.safety.CheckSettings` per controller and mode),
so no command chooses the check's flags by the kind of controller.

A ``MODULE:CLASS`` is imported with the current folder first on ``sys.path`` (as ``python -m``
would), so a ``mymod.py`` beside the user works with the installed ``gpcnav`` command too.
Episodes on Ray workers need the module importable there (installed, or on ``PYTHONPATH``).
"""
from __future__ import annotations

import importlib
import math
import os
import sys
from collections.abc import Callable
from dataclasses import asdict, dataclass, is_dataclass, replace
from pathlib import Path

from .errors import UsageError, comma_items
from .user_controllers import UserController, make_user, one_line as _one_line

__all__ = ["BUILTIN", "PEERS", "REGISTRY", "SHIELD_MODES", "DEFAULT_SHIELD", "Kind", "ControllerSpec", "make",
           "make_controller", "check", "check_settings", "shield_mode", "load_user_class", "describe", "spec_from_args",
           "parse_controller_list", "reads_planner_settings", "PLANNER_READERS", "UserController"]

PEERS = ("orca", "hrvo", "social_force", "mppi")
BASELINES = ("stand", "blind")
"""A robot that stands still and one that drives its reference blind (:mod:`gpcnav.peers.baselines`):
beside every result on recorded people."""
BUILTIN = ("gpc", "nn") + PEERS + BASELINES

PLANNER_READERS = ("gpc", "mppi")
"""The controllers made from the planner's settings (``--set``, ``--sample-time``, ``--horizon``,
``--solver``): the GPC, and MPPI with the GPC's cost and forecast. The network runs at the
settings it was trained at (its model file's), the navground peers, the baselines and a user's
class take none; behind the check with the GPC on standby (``--shield-fallback gpc``), every
controller's standby planner does (:func:`reads_planner_settings`)."""

SHIELD_MODES = ("off", "on", "gpc")
"""``off``: the bare controller; ``on``: behind the check layer, which falls back on the
controller's alternatives and its own manoeuvres; ``gpc``: the same with the GPC on standby
as the first fallback."""


def _gpc_check(controller, config, mode: str):
    """The planner replans at every sample: its plans (and alternatives) are trusted for the
    filter's trust time, and under the presets where it was measured better a plan passing on
    that trust alone gives way to an alternative of its own that keeps the margin all along
    (:data:`casadi_gpc.safety.SAFER_ALTERNATIVES`). Its own alternatives come before any
    fallback, so it never has the planner on standby behind it. (Its way out searched in two
    phases with ``robust_drive_in`` passed a rule on development seeds 4 and 5 and was shipped
    for an evening; on cases it never saw, seed 6, seed 1 and four held-out recordings, it
    drove into people more often, 4 -> 7, and was taken back: docs/data/deploy/robust_drive_in/.)
    Near walls, where the planner's settings have a margin there
    (:attr:`casadi_gpc.config.PlannerConfig.walls_margin_m`: ``improved``), the check keeps
    :data:`WALLS_CHECK_MARGIN_M` plus the planner's ``walls_sigmas`` standard deviations and
    searches its way out in two phases (BW5, adopted by a rule on unseen cases:
    docs/data/buildings/walls_margin/rule3.md); elsewhere it is the check above. Where every
    option loses the margin, options equal on the drive-in and on the expected discs are ranked
    by how late they move towards a person inside their uncertain disc (``robust_drive_ties``,
    adopted by a rule on unseen cases, 2026-11-30: docs/data/pedestrians/robust_ties/rule.md)."""
    from casadi_gpc.safety import CheckSettings, safer_alternatives_for
    near_walls = {} if getattr(config, "walls_margin_m", None) is None else dict(
        search=True, search_two_phase=True, search_near_walls=True, walls_margin_m=WALLS_CHECK_MARGIN_M,
        walls_sigmas=config.walls_sigmas)
    return CheckSettings(trust_plans=True, safer_alternatives=safer_alternatives_for(config), robust_drive_ties=True,
                         **near_walls)


WALLS_CHECK_MARGIN_M = 0.05
"""The GPC's check margin near walls: its open margin (:class:`casadi_gpc.safety.CheckSettings`'s
``margin_m``), only the uncertainty's inflation taken from the planner's near-walls setting.
0.02 m let the robot pass people within centimetres: two grazes in 200 files of navground's
corridor (docs/data/buildings/walls_margin/rule.md)."""


def _nn_check(controller, config, mode: str):
    """What a robot deploys (mode ``on``, the default): the network behind the planner-free
    check (numpy only, no CasADi). A plan network replans as often as the planner: its plans
    are trusted as the planner's, with its shifted previous plan kept as the safe candidate
    (docs/nn-plan.md: 2.8-11x fewer interventions than checked over the whole horizon). A
    one-command network's own roll-out is judged as its plan before the check steps in, and
    passes when it keeps the margin for :data:`casadi_gpc.safety.ROLLOUT_TRUST_S`; the check's
    own way out is searched (:meth:`casadi_gpc.safety.search.WayOutSearch.search`: a grid of held
    wheel-speed targets beside the fixed manoeuvres, the safe one nearest the network's
    command; where none is safe, the best of them continued with a second target:
    ``search_two_phase``, docs/nn-deploy.md, "A way out in two phases"), and a command passes
    when one of those keeps the margin after it
    (docs/nn-deploy.md: one collision in the 800 episodes of the crowd suites on seed 1, 6 in
    1 000 crossings among 10 walkers on seeds 1-5, more than the GPC among walls; fewer
    interventions than with the GPC on standby).
    Options that all lose the margin and are equal on the drive-in and the expected discs are
    ranked by the drive-in into the uncertain discs (``robust_drive_ties``, adopted by a rule on
    unseen cases, 2026-11-30: docs/data/pedestrians/robust_ties/nn_rule.md).
    Mode ``gpc`` keeps the GPC on standby behind the network instead of the search (CasADi;
    docs/nn-crowds.md, "The network's roll-out as its plan")."""
    from casadi_gpc.safety import ROLLOUT_TRUST_S, CheckSettings
    plans = bool(getattr(controller, "outputs_plans", False))
    rollouts = not plans
    if mode == "gpc":
        return CheckSettings(trust_plans=plans, previous_plan=plans, rollouts=rollouts,
                             trust_rollout_s=ROLLOUT_TRUST_S if rollouts else None, fallback="planner")
    return CheckSettings(trust_plans=plans, previous_plan=plans, rollouts=rollouts,
                         trust_rollout_s=ROLLOUT_TRUST_S if rollouts else None, search=True, search_two_phase=True,
                         robust_drive_ties=True, fallback="manoeuvres")


def _reactive_check(controller, config, mode: str):
    """A peer or a user's controller: nothing trusted, the whole horizon checked."""
    from casadi_gpc.safety import CheckSettings
    return CheckSettings(fallback="planner" if mode == "gpc" else "manoeuvres")


@dataclass(frozen=True)
class Kind:
    """One entry of the registry.

    Attributes
    ----------
    default_shield : str
        The shield mode (:data:`SHIELD_MODES`) the controller runs with unless told.
    check : callable
        ``check(controller, config, mode) -> CheckSettings``: what the check layer trusts
        from the made controller, for how long, and what it falls back on, in ``mode``.
    """

    default_shield: str
    check: Callable


REGISTRY = {
    "gpc": Kind("on", _gpc_check),
    "nn": Kind("on", _nn_check),
    **{name: Kind("off", _reactive_check) for name in PEERS + BASELINES},
}
"""Every built-in controller by name; a user's ``MODULE:CLASS`` is checked as a peer is."""

USER_CLASS = Kind("off", _reactive_check)

DEFAULT_SHIELD = {name: kind.default_shield for name, kind in REGISTRY.items()}
"""The shield mode each built-in controller runs with unless told (the others: ``off``)."""


def _kind(name: str) -> Kind:
    return REGISTRY.get(name, USER_CLASS)


def check_settings(name: str, controller, config, mode: str):
    """The :class:`~casadi_gpc.safety.CheckSettings` the registry declares for the made
    ``controller`` named ``name`` in shield mode ``mode``."""
    return _kind(name).check(controller, config, mode)


@dataclass(frozen=True)
class ControllerSpec:
    """Which controller, and how it is made (hashable and picklable: it travels to the
    worker processes, which make the controller once each).

    Attributes
    ----------
    name : str
        A name of :data:`BUILTIN` or ``MODULE:CLASS``.
    model : Path or None
        ``nn``: the ONNX model (None: the one shipped for the preset).
    shield : str or None
        The check layer's mode (``off``, ``on``, ``gpc``:
        :data:`gpcnav.commands.common.SHIELD_MODES`); None: the controller's default
        (:attr:`mode`).
    passes : int or None
        ``nn``: 1 or 2 passes, None for what the model file says.
    walls_model, crowd_model : Path or None
        ``nn``: the walls network, which answers with a wall within 4 m, and the crowd network, which
        answers where the model cannot hold the obstacles in range (None: the ones shipped for the
        preset, where the model is the shipped one; ``gpcnav train --init`` trains one further).
    """

    name: str
    model: Path | None = None
    shield: str | None = None
    passes: int | None = None
    walls_model: Path | None = None
    crowd_model: Path | None = None

    @property
    def mode(self) -> str:
        """The shield mode it runs with: the one asked for, else the controller's default
        (``on`` for gpc and nn, ``off`` for the others)."""
        mode = self.shield or _kind(self.name).default_shield
        return "on" if mode == "brake" else mode

    @property
    def label(self) -> str:
        """The name a document and a table show: the name, and the shield mode when it is
        not the controller's default."""
        default = ControllerSpec(self.name).mode
        return self.name if self.mode == default else f"{self.name}[shield={self.mode}]"

    @property
    def is_user_class(self) -> bool:
        return self.name not in BUILTIN


def check_controller_name(name: str, what: str = "--controller") -> None:
    """Refuse (``ValueError`` naming ``what``) a name that is neither a built-in controller nor
    ``MODULE:CLASS`` in form; the class itself is imported when the controller is made."""
    module_name, sep, class_name = name.partition(":")
    if name not in BUILTIN and not (sep and module_name and class_name):
        raise ValueError(f"{what} {name!r}: not a controller (choose from {', '.join(BUILTIN)}, or MODULE:CLASS)")


def load_user_class(text: str) -> type:
    """The class named by ``MODULE:CLASS`` (``CLASS`` may be dotted), imported with the
    current folder first on ``sys.path``. A one-line :class:`UsageError` when the module
    cannot be imported or has no such class."""
    try:
        check_controller_name(text)
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    module_name, _, class_name = text.partition(":")
    cwd = os.getcwd()
    if cwd not in sys.path:
        sys.path.insert(0, cwd)
    try:
        obj = importlib.import_module(module_name)
    except Exception as exc:  # noqa: BLE001  (any failure of the user's module is a usage error)
        raise UsageError(f"--controller {text}: cannot import module {module_name!r} ({_one_line(exc)})") from None
    for part in class_name.split("."):
        if not hasattr(obj, part):
            raise UsageError(f"--controller {text}: module {module_name!r} has no class {class_name!r}")
        obj = getattr(obj, part)
    if not isinstance(obj, type):
        raise UsageError(f"--controller {text}: {class_name!r} in {module_name!r} is not a class")
    return obj


def _make_peer(name: str, config, robot):
    if name == "mppi":
        try:
            from .peers.mppi_peer import MPPIPeer
        except ImportError as exc:
            raise UsageError(f"--controller mppi needs torch and pytorch-mppi (pip install 'gpcnav[train]'): "
                             f"{_one_line(exc)}") from None
        return MPPIPeer(config=config, robot=robot)
    from .peers.navground_peer import NAVGROUND_PEERS, NavgroundPeer
    return NavgroundPeer(NAVGROUND_PEERS[name](), robot)


def _make_base(spec: ControllerSpec, config, robot):
    """The bare controller ``spec`` names."""
    if spec.name == "gpc":
        from casadi_gpc.planner.gpc import GPCController
        return GPCController(config, robot)
    if spec.name == "nn":
        try:
            from nn_export import OnnxPolicy
            return OnnxPolicy(spec.model, preset=config.name, robot=robot,
                              two_pass=None if spec.passes is None else spec.passes == 2,
                              **{k: v for k, v in (("walls_model", spec.walls_model),
                                                   ("crowd_model", spec.crowd_model)) if v is not None})
        except ImportError as exc:
            raise UsageError(f"--controller nn is not available: {exc}") from None
        except (FileNotFoundError, ValueError) as exc:
            raise UsageError(str(exc)) from None
    if spec.name in BASELINES:
        from .peers.baselines import BlindTracker, StandStill
        return (StandStill if spec.name == "stand" else BlindTracker)(robot)
    if spec.name in PEERS:
        return _make_peer(spec.name, config, robot)
    return make_user(spec.name, load_user_class(spec.name))


def make(spec: ControllerSpec, config, robot):
    """The controller ``spec`` names, for the planner preset ``config`` and the scenario's
    ``robot``, behind the check layer as its mode and the registry say: an object with
    ``reset()``, ``decide(observation)`` and ``sample_time_s``."""
    mode = spec.mode
    if mode not in SHIELD_MODES:
        raise UsageError(f"unknown shield mode {spec.shield!r} (choose from {', '.join(SHIELD_MODES)})")
    controller = _make_base(spec, config, robot)
    if mode == "off":
        return controller
    _check_standby(spec, controller, config)
    from casadi_gpc.safety import Shield
    settings = check_settings(spec.name, controller, config, mode)
    try:
        return Shield(controller, robot, settings, planner_config=config)
    except ImportError as exc:  # the planner on standby needs CasADi
        raise UsageError(f"--shield-fallback gpc needs the planner ({exc}); use --shield-fallback brake") from None


def _check_standby(spec: ControllerSpec, controller, config) -> None:
    """Refuse the planner on standby (``--shield-fallback gpc``) behind a controller that
    decides at another rate: its plan has the planner's steps, the check the controller's, and
    the first intervention stopped with a shape error (navground's peers decide every 0.1 s)."""
    if spec.mode == "gpc" and not math.isclose(float(controller.sample_time_s), float(config.sample_time_s)):
        raise UsageError(f"--shield-fallback gpc: {spec.name} decides every {float(controller.sample_time_s):g} s and the "
                         f"planner on standby every {float(config.sample_time_s):g} s; the check needs one rate "
                         f"(use --shield-fallback brake, or --set sample_time_s)")


def make_controller(kind: str, config, robot, model=None, shield: str | None = None, passes: int | None = None):
    """:func:`make` from loose arguments (``shield``: a mode of :data:`SHIELD_MODES`, or
    ``brake``, the older name of ``on``; None: the controller's default)."""
    return make(ControllerSpec(kind, model, shield, passes), config, robot)


def reads_planner_settings(spec: ControllerSpec) -> bool:
    """Whether the controller ``spec`` names reads the planner's settings (:data:`PLANNER_READERS`,
    or any controller behind the check with the GPC on standby)."""
    return spec.name in PLANNER_READERS or spec.mode == "gpc"


def check(spec: ControllerSpec, config, robot) -> None:
    """Refuse, before any work and in one line, a controller that cannot be made: an unknown
    name, a user class that does not load or answer the protocol, ``mppi`` without torch,
    ``nn`` with a bad model, an unknown shield mode. Options meant for ``nn`` given to
    another controller are refused too."""
    if spec.name != "nn" and any(v is not None for v in (spec.model, spec.passes, spec.walls_model, spec.crowd_model)):
        raise UsageError(f"--model, --walls-model, --crowd-model and --passes are options of --controller nn, not of "
                         f"{spec.name}")
    if spec.mode not in SHIELD_MODES:
        raise UsageError(f"unknown shield mode {spec.shield!r} (choose from {', '.join(SHIELD_MODES)})")
    if spec.name == "nn":
        make(replace(spec, shield="off"), config, robot)  # the models load
    elif spec.name in PEERS + BASELINES or spec.is_user_class:
        _check_standby(spec, make(ControllerSpec(spec.name, shield="off"), config, robot), config)


def check_scenarios(spec: ControllerSpec, config, scenarios) -> None:
    """:func:`check` for the robot of every scenario of a run, each distinct robot once,
    before any work: a network trained for another robot than one of the files' is refused in
    one line that names that file (it was found only when its episode came, after minutes of
    other work; the first file's robot was refused without its name, which of forty files
    left to guess)."""
    seen = []
    for sc in scenarios:
        if sc.robot in seen:
            continue
        seen.append(sc.robot)
        try:
            check(spec, config, sc.robot)
        except UsageError as exc:
            if len(seen) == 1 and not (sc.source and len(scenarios) > 1):
                raise  # one file, or a suite's one robot: nothing to tell apart
            raise UsageError(f"{exc} (the robot of {sc.source or sc.name})") from None


def describe(controller) -> dict:
    """What a document records of a controller: its class, sample time and settings (the
    peers' settings dataclasses, the GPC's solver, the network's model)."""
    inner = getattr(controller, "policy", controller)
    inner = inner.wrapped if isinstance(inner, UserController) else inner
    out = {"class": f"{type(inner).__module__}.{type(inner).__qualname__}",
           "sample_time_s": float(controller.sample_time_s)}
    settings = getattr(inner, "settings", None)
    if is_dataclass(settings) and not isinstance(settings, type):
        try:
            out["settings"] = _plain(asdict(settings))
        except Exception:  # noqa: BLE001  (a user's field that cannot be copied)
            out["settings"] = repr(settings)
        behaviour = getattr(settings, "behaviour", "")
        if behaviour:
            out["library"] = f"navground {_version('navground')} ({behaviour})"
    if out["class"].endswith("MPPIPeer"):
        out["library"] = f"pytorch-mppi {_version('pytorch_mppi')}, torch {_version('torch')}"
        out["horizon"] = int(inner.config.horizon)
    return out


def _plain(value):
    """``value`` as JSON data: a user's settings may hold a Path, an array, a numpy scalar, an
    infinity (a Path stopped the document's write after the whole run, a traceback)."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if not isinstance(value, str) and callable(getattr(value, "tolist", None)):  # numpy's
        return _plain(value.tolist())
    ok = value is None or isinstance(value, (bool, int, str)) or (isinstance(value, float) and math.isfinite(value))
    return value if ok else str(value)


def _version(dist: str) -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version(dist)
    except PackageNotFoundError:
        return "?"


def parse_controller_list(text: str) -> list[str]:
    """``"gpc,nn,orca"`` -> the names, in order, each once."""
    names = comma_items(text, "--controllers")  # 'nn,' was nn alone, the gap unsaid
    if not names:
        raise UsageError("--controllers: give at least one controller")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:  # dropped silently before: a one-row table where two were asked for
        raise UsageError(f"--controllers: {', '.join(twice)} given twice (each controller runs once)")
    return names


def shield_mode(args, kind: str | None = None) -> str:
    """The check layer's mode (:data:`SHIELD_MODES`) from the controller options."""
    kind = kind or getattr(args, "controller", "gpc")
    default = DEFAULT_SHIELD.get(kind, "off")
    mode = getattr(args, "shield", None) or default
    if mode == "on" and default != "off":
        # --shield asks for the check layer, which gpc and nn run behind already: as they do
        # (for nn, the planner-free check; --shield-fallback gpc puts the GPC on standby)
        mode = default
    fallback = getattr(args, "shield_fallback", None)
    if mode != "off" and fallback is not None:
        mode = "gpc" if fallback == "gpc" else "on"
    return mode


def spec_from_args(args, name: str | None = None) -> ControllerSpec:
    """The :class:`ControllerSpec` the options give (:func:`gpcnav.commands.common.add_controller_arguments`).
    With ``name`` (one of ``--controllers``) the network's options go to ``nn`` only; without,
    they go to ``--controller`` as given, and :func:`check` refuses them for another one."""
    if name is None:
        name = args.controller
        return ControllerSpec(name, args.model, shield_mode(args, name), args.passes, args.walls_model,
                              args.crowd_model)
    is_nn = name == "nn"
    return ControllerSpec(name, args.model if is_nn else None, shield_mode(args, name), args.passes if is_nn else None,
                          args.walls_model if is_nn else None, args.crowd_model if is_nn else None)
