"""The one controller registry: every controller a command can run, by name.

``simulate``, ``evaluate``, ``compare``, ``bench`` and the Gymnasium environment make their
controllers here, so a name means the same thing everywhere:

========================  =============================================================
``gpc``                   the GPC planner (:class:`casadi_gpc.gpc.GPCController`)
``nn``                    the network (:class:`nn_export.OnnxPolicy`, behind its filter)
``orca``, ``hrvo``,       navground's behaviours with its differential-drive kinematics
``social_force``          (:mod:`gpcnav.peers.navground_peer`)
``mppi``                  pytorch-mppi on the GPC's cost (:mod:`gpcnav.peers.mppi_peer`;
                          needs torch, the ``train`` extra)
``MODULE:CLASS``          any importable class made with no arguments that answers the
                          Policy protocol (``reset()``, ``decide(observation)``,
                          ``sample_time_s``)
========================  =============================================================

``gpc`` and ``nn`` are built by :func:`gpcnav.commands.common.make_controller`, as the
commands always built them. A name that cannot be made is a :class:`~gpcnav.errors.UsageError`
(one line, exit 2), raised by :func:`check` before any work. Any of them runs behind the
controller-agnostic safety check layer (:class:`casadi_gpc.safety.Shield`) as the shield mode
says (``--shield``, ``--no-shield``, ``--shield-fallback``; :data:`~gpcnav.commands.common.SHIELD_MODES`):
by default ``gpc`` and ``nn`` do, the peers and a user's class run bare, as their users run them.

A ``MODULE:CLASS`` is imported with the current folder first on ``sys.path`` (as ``python -m``
would), so a ``mymod.py`` beside the user works with the installed ``gpcnav`` command too.
Episodes on Ray workers need the module importable there (installed, or on ``PYTHONPATH``).
"""
from __future__ import annotations

import importlib
import math
import os
import sys
from dataclasses import asdict, dataclass, is_dataclass
from pathlib import Path

from .errors import UsageError

__all__ = ["BUILTIN", "PEERS", "ControllerSpec", "make", "check", "load_user_class", "describe", "spec_from_args",
           "parse_controller_list"]

PEERS = ("orca", "hrvo", "social_force", "mppi")
BUILTIN = ("gpc", "nn") + PEERS


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
    """

    name: str
    model: Path | None = None
    shield: str | None = None
    passes: int | None = None

    @property
    def mode(self) -> str:
        """The shield mode it runs with: the one asked for, else the controller's default
        (``on`` for gpc, ``gpc`` for nn, ``off`` for the others)."""
        from .commands.common import DEFAULT_SHIELD
        mode = self.shield or DEFAULT_SHIELD.get(self.name, "off")
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


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def load_user_class(text: str) -> type:
    """The class named by ``MODULE:CLASS`` (``CLASS`` may be dotted), imported with the
    current folder first on ``sys.path``. A one-line :class:`UsageError` when the module
    cannot be imported or has no such class."""
    module_name, sep, class_name = text.partition(":")
    if not sep or not module_name or not class_name:
        raise UsageError(f"--controller {text!r}: not a controller (choose from {', '.join(BUILTIN)}, "
                         "or MODULE:CLASS)")
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


def _check_protocol(text: str, controller) -> None:
    """Refuse, in one line, an object that does not answer the Policy protocol."""
    missing = [m for m in ("decide", "reset") if not callable(getattr(controller, m, None))]
    if missing:
        raise UsageError(f"--controller {text}: does not answer the Policy protocol (no {' and no '.join(missing)}"
                         f" method; see README, 'Your own controller')")
    T = getattr(controller, "sample_time_s", None)
    if isinstance(T, bool) or not isinstance(T, (int, float)) or not math.isfinite(T) or T <= 0:
        raise UsageError(f"--controller {text}: does not answer the Policy protocol (sample_time_s must be a "
                         f"positive number of seconds, got {T!r})")


def _make_user(text: str):
    cls = load_user_class(text)
    try:
        controller = cls()
    except Exception as exc:  # noqa: BLE001
        raise UsageError(f"--controller {text}: cannot be made with no arguments ({_one_line(exc)})") from None
    _check_protocol(text, controller)
    return controller


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


def _shielded(controller, config, robot, mode: str):
    """A peer or a user's controller behind the check layer (:func:`gpcnav.commands.common.behind_shield`).
    The shield's own obstacle filters run at the controller's sample time: with the planner's
    noise per second, or a 6 s check at 0.1 s loses every heading (docs/peers.md)."""
    from casadi_gpc.ekf import EKFSettings
    from .commands.common import behind_shield
    return behind_shield(controller, config, robot, mode,
                         ekf_settings=EKFSettings().for_sample_time(controller.sample_time_s))


def make(spec: ControllerSpec, config, robot):
    """The controller ``spec`` names, for the planner preset ``config`` and the scenario's
    ``robot``: an object with ``reset()``, ``decide(observation)`` and ``sample_time_s``."""
    if spec.name in ("gpc", "nn"):
        from .commands.common import make_controller
        return make_controller(spec.name, config, robot, spec.model, spec.mode, spec.passes)
    controller = _make_peer(spec.name, config, robot) if spec.name in PEERS else _make_user(spec.name)
    return _shielded(controller, config, robot, spec.mode)


def check(spec: ControllerSpec, config, robot) -> None:
    """Refuse, before any work and in one line, a controller that cannot be made: an unknown
    name, a user class that does not load or answer the protocol, ``mppi`` without torch,
    ``nn`` with a bad model, an unknown shield mode. Options meant for ``nn`` given to
    another controller are refused too."""
    from .commands.common import SHIELD_MODES
    if spec.name != "nn" and (spec.model is not None or spec.passes is not None):
        raise UsageError(f"--model and --passes are options of --controller nn, not of {spec.name}")
    if spec.mode not in SHIELD_MODES:
        raise UsageError(f"unknown shield mode {spec.shield!r} (choose from {', '.join(SHIELD_MODES)})")
    if spec.name == "nn":
        make(ControllerSpec("nn", spec.model, "off", spec.passes), config, robot)  # the model loads
    elif spec.name in PEERS or spec.is_user_class:
        make(ControllerSpec(spec.name, shield="off"), config, robot)


def describe(controller) -> dict:
    """What a document records of a controller: its class, sample time and settings (the
    peers' settings dataclasses, the GPC's solver, the network's model)."""
    inner = getattr(controller, "policy", controller)
    out = {"class": f"{type(inner).__module__}.{type(inner).__qualname__}",
           "sample_time_s": float(controller.sample_time_s)}
    settings = getattr(inner, "settings", None)
    if is_dataclass(settings):
        out["settings"] = asdict(settings)
        behaviour = getattr(settings, "behaviour", "")
        if behaviour:
            out["library"] = f"navground {_version('navground')} ({behaviour})"
    if out["class"].endswith("MPPIPeer"):
        out["library"] = f"pytorch-mppi {_version('pytorch_mppi')}, torch {_version('torch')}"
        out["horizon"] = int(inner.config.horizon)
    return out


def _version(dist: str) -> str:
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version(dist)
    except PackageNotFoundError:
        return "?"


def parse_controller_list(text: str) -> list[str]:
    """``"gpc,nn,orca"`` -> the names, in order, each once."""
    names = [n.strip() for n in text.split(",") if n.strip()]
    if not names:
        raise UsageError("--controllers: give at least one controller")
    return list(dict.fromkeys(names))


def spec_from_args(args, name: str | None = None) -> ControllerSpec:
    """The :class:`ControllerSpec` the options give (:func:`gpcnav.commands.common.add_controller_arguments`).
    With ``name`` (one of ``--controllers``) the network's options go to ``nn`` only; without,
    they go to ``--controller`` as given, and :func:`check` refuses them for another one."""
    from .commands.common import shield_mode
    if name is None:
        name = args.controller
        return ControllerSpec(name, args.model, shield_mode(args, name), args.passes)
    is_nn = name == "nn"
    return ControllerSpec(name, args.model if is_nn else None, shield_mode(args, name), args.passes if is_nn else None)
