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
(one line, exit 2), raised by :func:`check` before any work. ``--shield`` puts any of them
behind the controller-agnostic safety check layer (:class:`casadi_gpc.safety.Shield`).

A ``MODULE:CLASS`` is imported with the current folder first on ``sys.path`` (as ``python -m``
would), so a ``mymod.py`` beside the user works with the installed ``gpcnav`` command too.
Episodes on Ray workers need the module importable there (installed, or on ``PYTHONPATH``).
"""
from __future__ import annotations

import argparse
import importlib
import math
import os
import sys
from dataclasses import asdict, dataclass, is_dataclass
from pathlib import Path

from .errors import UsageError

__all__ = ["BUILTIN", "PEERS", "ControllerSpec", "make", "check", "load_user_class", "describe",
           "add_controller_arguments", "spec_from_args", "parse_controller_list"]

PEERS = ("orca", "hrvo", "social_force", "mppi")
BUILTIN = ("gpc", "nn") + PEERS
SAFETY_MODES = ("gpc", "brake", "off")


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
    safety : {"gpc", "brake", "off"}
        ``nn``: its safety filter's fallback, or no filter.
    passes : int or None
        ``nn``: 1 or 2 passes, None for what the model file says.
    shield : bool
        Behind :class:`casadi_gpc.safety.Shield`.
    """

    name: str
    model: Path | None = None
    safety: str = "gpc"
    passes: int | None = None
    shield: bool = False

    @property
    def label(self) -> str:
        """The name a document and a table show."""
        return self.name + ("+shield" if self.shield else "")

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


def _shielded(controller, robot):
    try:
        from casadi_gpc.safety import Shield
    except ImportError:
        raise UsageError("--shield: casadi_gpc.safety.Shield is not available in this version") from None
    return Shield(controller, robot=robot, fallback=None)


def make(spec: ControllerSpec, config, robot):
    """The controller ``spec`` names, for the planner preset ``config`` and the scenario's
    ``robot``: an object with ``reset()``, ``decide(observation)`` and ``sample_time_s``."""
    if spec.name in ("gpc", "nn"):
        from .commands.common import make_controller
        controller = make_controller(spec.name, config, robot, spec.model, spec.safety, spec.passes)
    elif spec.name in PEERS:
        controller = _make_peer(spec.name, config, robot)
    else:
        controller = _make_user(spec.name)
    return _shielded(controller, robot) if spec.shield else controller


def check(spec: ControllerSpec, config, robot) -> None:
    """Refuse, before any work and in one line, a controller that cannot be made: an unknown
    name, a user class that does not load or answer the protocol, ``mppi`` without torch,
    ``nn`` with a bad model, ``--shield`` where there is none. Options meant for ``nn``
    given to another controller are refused too."""
    if spec.name != "nn" and (spec.model is not None or spec.passes is not None):
        raise UsageError(f"--model and --passes are options of --controller nn, not of {spec.name}")
    if spec.safety not in SAFETY_MODES:
        raise UsageError(f"unknown safety mode {spec.safety!r} ({', '.join(SAFETY_MODES)})")
    if spec.name == "nn":
        make(ControllerSpec("nn", spec.model, "off", spec.passes), config, robot)  # the model loads
    elif spec.name in PEERS or spec.is_user_class:
        make(ControllerSpec(spec.name), config, robot)
    if spec.shield:
        try:
            from casadi_gpc.safety import Shield  # noqa: F401
        except ImportError:
            raise UsageError("--shield: casadi_gpc.safety.Shield is not available in this version") from None


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


def add_controller_arguments(p: argparse.ArgumentParser, many: bool = False) -> None:
    """``--controller NAME`` (or ``--controllers LIST`` with ``many``), the network's options,
    ``--shield`` and the planner preset options."""
    from .commands.common import add_preset_arguments
    names = ", ".join(BUILTIN)
    if many:
        p.add_argument("--controllers", default="gpc,nn", metavar="LIST",
                       help=f"comma-separated controllers ({names}, or MODULE:CLASS; default gpc,nn)")
    else:
        p.add_argument("--controller", default="gpc", metavar="NAME",
                       help=f"{names}, or MODULE:CLASS: a class of yours that answers the Policy protocol "
                            "(README, 'Your own controller'); default gpc")
    p.add_argument("--shield", action="store_true",
                   help="put the controller behind the safety check layer (casadi_gpc.safety.Shield)")
    p.add_argument("--model", type=Path, default=None,
                   help="ONNX model for --controller nn (default: the one shipped for --preset)")
    p.add_argument("--no-safety-filter", action="store_true",
                   help="--controller nn: run the bare network, without the safety filter (docs/faults.md)")
    p.add_argument("--safety-fallback", choices=("gpc", "brake"), default="gpc",
                   help="--controller nn: what the safety filter hands over to: the GPC on standby (default) "
                        "or the best braking/turning manoeuvre")
    p.add_argument("--passes", type=int, choices=(1, 2), default=None,
                   help="--controller nn: one pass or the paper's two passes (default: what the model file "
                        "says, docs/nn.md)")
    p.add_argument("--solver", default=None, metavar="NAME",
                   help="--controller gpc: the NLP solver (default: the preset's; see docs/solvers.md)")
    add_preset_arguments(p)


def spec_from_args(args, name: str | None = None) -> ControllerSpec:
    """The :class:`ControllerSpec` the options give. With ``name`` (one of ``--controllers``),
    the network's options go to ``nn`` only; without, they go to ``--controller`` as given,
    and :func:`check` refuses them for another controller."""
    safety = "off" if args.no_safety_filter else args.safety_fallback
    if name is None:
        name = args.controller
        return ControllerSpec(name, args.model, safety if name == "nn" else "gpc", args.passes, bool(args.shield))
    is_nn = name == "nn"
    return ControllerSpec(name, args.model if is_nn else None, safety if is_nn else "gpc",
                          args.passes if is_nn else None, bool(args.shield))
