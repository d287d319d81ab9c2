"""The finished episodes of an evaluation, kept on disk as they finish, so that ``evaluate``
and ``compare`` stopped at any point (kill -9 included) and run again with the same command
reuse them and run only the rest (docs/evaluation.md, "Runs that resume").

Where: ``OUT.episodes/`` beside ``--out OUT`` (without ``--out``:
``$GPCNAV_CACHE_DIR/episodes``, default ``~/.cache/gpcnav/episodes``). One JSON file per
finished episode, named by its key and written whole or not at all (a temporary file,
fsync, rename: :func:`casadi_gpc.io.atomic_file`) by the parent process alone, so a killed
run leaves finished episodes and nothing half-written; the backend (local processes or Ray)
makes no difference. After the document is written the run removes its own episodes, and the
folder if that leaves it empty (``--keep-episodes`` keeps them).

The key of an episode is a SHA-256 of everything that decides it (:func:`run_key`,
:func:`episode_key`): the scenario's whole content (robot, reference, movers, sensing and its
seed, injected faults, name; not the file's path or description), the controller (name,
check-layer mode, passes, the model file's bytes, a user class's module source, what
``controller_extra`` records: solver, peers' settings and library versions), the planner
configuration after every override (``PlannerConfig.to_dict``), and a stamp of the code
(:func:`code_stamp`: the bytes of every source file of ``casadi_gpc``, ``scenarios``,
``nn_export/runtime``, the shipped models, ``gpcnav/controllers.py``, ``gpcnav/peers`` and the
episode runner, and the versions of the numerical libraries). A changed setting or an edited
planner gives other keys: old episodes are never mixed in, only left unused. The worker
count and the backend are not in the key: they do not change an episode's outcome.

What an episode's file holds is what the documents are made from: its
:class:`~scenarios.metrics.EpisodeMetrics`, its decision times and its event counts. Decision
times are measurements: a reused episode keeps those measured when it ran, and the
document's ``compute_time_s`` is over the measurements of all its episodes, old and new.
"""
from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import platform
import time
from dataclasses import asdict, fields, is_dataclass
from enum import Enum
from pathlib import Path

import numpy as np

from casadi_gpc.io import NAME_MAX, abandoned, write_text

__all__ = ["EpisodeStore", "store_folder", "code_stamp", "run_key", "episode_key", "canonical", "STORE_FORMAT"]

STORE_FORMAT = 1
"""Bumped when what an episode's file holds changes."""

_CODE = ("casadi_gpc", "scenarios", "nn_export/runtime", "nn_export/models", "gpcnav/peers", "gpcnav/controllers.py",
         "gpcnav/commands/evaluate.py")
"""The sources an episode's result depends on (paths under the folder holding the packages)."""
_LIBRARIES = ("numpy", "scipy", "casadi", "onnxruntime", "navground", "torch", "pytorch-mppi")


def store_folder(out: Path | None) -> Path:
    """Where the episodes of a run writing ``out`` are kept."""
    if out is not None:
        name = out.name + ".episodes"
        if len(name.encode()) > NAME_MAX:  # an --out of 247 to 255 bytes: a name as long, no file system takes
            stem = out.name.encode()[:NAME_MAX - len(".episodes") - 13].decode(errors="ignore")
            name = f"{stem}-{hashlib.sha256(out.name.encode()).hexdigest()[:12]}.episodes"
        return out.with_name(name)
    from casadi_gpc.io import cache_dir
    return cache_dir() / "episodes"


_PLAIN = frozenset((float, int, bool, str, type(None)))
"""Types that :func:`canonical` gives back as they are (exactly these: a subclass, such as
numpy's float64, goes the long way)."""


def canonical(obj):
    """``obj`` as plain JSON data, the same in every process: dataclasses as their fields
    (with the class name), tuples as lists, arrays as lists, floats as they are (JSON keeps
    every bit of a float)."""
    if is_dataclass(obj) and not isinstance(obj, type):
        return {"__class__": type(obj).__qualname__, **{f.name: canonical(getattr(obj, f.name)) for f in fields(obj)}}
    if isinstance(obj, dict):
        return {str(k): canonical(v) for k, v in sorted(obj.items(), key=lambda kv: str(kv[0]))}
    if type(obj) in (list, tuple):
        # rows of numbers (a track's 0.04 s rows, 10^5 of them: a second a scenario the long way)
        if all(type(v) in _PLAIN for v in obj):
            return list(obj)
        rows = [list(v) if type(v) in (list, tuple) and all(type(x) in _PLAIN for x in v) else None for v in obj]
        return [canonical(v) if r is None else r for v, r in zip(obj, rows)]
    if isinstance(obj, (list, tuple)):
        return [canonical(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return {"__array__": list(obj.shape), "dtype": str(obj.dtype), "data": canonical(obj.tolist())}
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, Enum):
        return canonical(obj.value)
    if isinstance(obj, Path):
        return str(obj)
    if obj is None or isinstance(obj, (bool, int, float, str)):
        return obj
    text = repr(obj)
    if " at 0x" in text:  # an address differs from run to run: such an object cannot be a key
        raise TypeError(f"cannot key an episode on a {type(obj).__name__}")
    return text


def _digest(data) -> str:
    text = json.dumps(canonical(data), sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


_STAMP: dict[str, str] = {}


def code_stamp() -> str:
    """A digest of the code and libraries an episode's result depends on (computed once per
    process: a few milliseconds)."""
    if "stamp" not in _STAMP:
        root = Path(importlib.util.find_spec("casadi_gpc").origin).parents[1]
        h = hashlib.sha256()
        for rel in _CODE:
            base = root / rel
            files = sorted(p for p in base.rglob("*") if p.is_file() and "__pycache__" not in p.parts) \
                if base.is_dir() else [base]
            for p in files:
                if p.suffix in (".py", ".onnx", ".json", ".toml") and p.exists():
                    h.update(str(p.relative_to(root)).encode() + b"\0" + p.read_bytes() + b"\0")
        from importlib.metadata import PackageNotFoundError, version
        for dist in _LIBRARIES:
            try:
                h.update(f"{dist}={version(dist)}\0".encode())
            except PackageNotFoundError:
                h.update(f"{dist}=-\0".encode())
        h.update(f"python={platform.python_version()}\0".encode())
        _STAMP["stamp"] = h.hexdigest()
    return _STAMP["stamp"]


_OURS = ("casadi_gpc", "scenarios", "nn_export", "gpcnav")


def _user_module_digest(name: str) -> str | None:
    """The source of a user's ``MODULE:CLASS`` module and of every module it brought in from
    its own folder (a helper beside it; found by an audit: an edited helper's episodes were
    mixed with the old ones), by path; None if it has no file. Modules of the standard library,
    of installed packages and of gpcnav's own packages (in the code stamp) are not its own."""
    import sys
    import sysconfig
    module = name.partition(":")[0]
    try:
        spec = importlib.util.find_spec(module)
    except (ImportError, ValueError):
        return None
    origin = getattr(spec, "origin", None)
    if not origin or not Path(origin).is_file():
        return None
    try:
        importlib.import_module(module)  # (the controller is made from it anyway): what it imports
    except Exception:  # noqa: BLE001 (its own error is reported where the controller is made)
        return _file_digest(Path(origin))
    home = Path(origin).resolve().parent
    installed = {Path(p).resolve() for p in (sysconfig.get_paths()["purelib"], sysconfig.get_paths()["platlib"],
                                            sysconfig.get_paths()["stdlib"])}
    files = {Path(origin).resolve()}
    for mod in list(sys.modules.values()):
        f = getattr(mod, "__file__", None)
        top = (getattr(mod, "__name__", "") or "").partition(".")[0]
        if not f or top in _OURS or not f.endswith(".py"):
            continue
        f = Path(f).resolve()
        if f.is_relative_to(home) and not any(f.is_relative_to(i) for i in installed) and f.is_file():
            files.add(f)
    return _digest({str(f.relative_to(home)): _file_digest(f) for f in sorted(files)})


def run_key(spec, config, extra: dict) -> str:
    """The part of every episode's key that one controller's run shares: the controller
    (``spec``: a :class:`gpcnav.controllers.ControllerSpec`; ``extra``: what the document
    records of how it was made), the planner configuration and the code. The settings that
    change only the planner's speed (:data:`~gpcnav.commands.common.SPEED_ONLY`: the solve
    lanes, fitted to the workers) are left out, as the worker count is."""
    from .common import SPEED_ONLY
    def digest(model):
        return _file_digest(Path(model)) if model is not None and Path(model).is_file() else model
    return _digest({
        "format": STORE_FORMAT, "code": code_stamp(),
        "config": {k: v for k, v in config.to_dict().items() if k not in SPEED_ONLY},
        "controller": {"name": spec.name, "mode": spec.mode, "passes": spec.passes, "label": spec.label,
                       "model": digest(spec.model),
                       **{k: digest(v) for k, v in (("walls_model", spec.walls_model),
                                                    ("crowd_model", spec.crowd_model)) if v is not None},
                       "user_module": _user_module_digest(spec.name) if spec.is_user_class else None},
        "extra": extra,
    })


def episode_key(run: str, scenario) -> str:
    """The key of one episode: the run's key and the scenario's content (not the path of the
    file it came from, nor its description)."""
    from dataclasses import replace
    return _digest({"run": run, "scenario": replace(scenario, source="", description="")})


class EpisodeStore:
    """The finished episodes in ``folder``, one file ``<key>.json`` each.

    Results are ``(EpisodeMetrics, compute times, events)`` as the worker returns them."""

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        self.written: list[Path] = []

    def _path(self, key: str) -> Path:
        return self.folder / f"{key}.json"

    def get(self, key: str):
        """The stored result of ``key``, or None (absent, or unreadable: then it is redone)."""
        from scenarios.metrics import EpisodeMetrics
        path = self._path(key)
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
            if doc.get("format") != STORE_FORMAT or doc.get("key") != key:
                return None
            metrics = EpisodeMetrics(**doc["metrics"])
            times = [float(t) for t in doc["compute_time_s"]]
            events = {str(k): int(v) for k, v in doc["events"].items()}
        except (OSError, ValueError, TypeError, KeyError, AttributeError):
            return None
        return metrics, times, events

    def put(self, key: str, result) -> None:
        """Keep one finished episode (whole or not at all)."""
        metrics, times, events = result
        doc = {"format": STORE_FORMAT, "key": key, "scenario": metrics.scenario, "controller": metrics.controller,
               "metrics": asdict(metrics), "compute_time_s": [float(t) for t in times],
               "events": {k: int(v) for k, v in events.items()}}
        path = self._path(key)
        write_text(path, json.dumps(doc, allow_nan=True, default=_plain) + "\n")
        self.written.append(path)

    def remove(self, keys) -> None:
        """Remove the episodes ``keys`` (a finished run's), then the folder if it is empty."""
        for key in keys:
            self._path(key).unlink(missing_ok=True)
        try:
            for stale in self.folder.glob(".*.json"):  # a killed write's temporary, not a running one's
                if abandoned(stale) or time.time() - stale.stat().st_mtime > 600:
                    stale.unlink(missing_ok=True)
            os.rmdir(self.folder)
        except OSError:
            pass  # other runs' episodes are still there, or it was never made


def _plain(o):
    if isinstance(o, np.generic):
        return o.item()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")
