"""Writing outputs whole or not at all: a temporary file in the same folder, flushed to
disk, then renamed over the target. A crash (kill -9 included) leaves the old file or the
new one, never half of one."""
from __future__ import annotations

import contextlib
import hashlib
import json
import os
import re
import shutil
import socket
import tempfile
import threading
import zipfile
import zlib
from glob import escape as glob_escape
from pathlib import Path

import numpy as np

__all__ = ["UNREADABLE_NPZ", "atomic_file", "abandoned", "sweep_abandoned", "writer_tag", "request_stop",
           "stop_requested", "clear_stop", "json_default", "write_json", "write_text", "write_bytes", "save_figure", "cache_dir"]

UNREADABLE_NPZ = (zipfile.BadZipFile, EOFError, zlib.error, ValueError)
"""What numpy's ``np.load`` raises on an ``.npz`` that is not a whole archive (cut short in a copy,
damaged on disk): the readers of shards and weights say so in one line naming the file."""


_STOP = threading.Event()


def request_stop() -> None:
    """Say that the command is stopping (Ctrl-C, SIGTERM: ``gpcnav.cli``): from now on
    :func:`atomic_file` writes nothing, so that work finished after the stop was asked (a solve
    the interrupt broke, taken for a failed one) is never kept as if whole."""
    _STOP.set()


def stop_requested() -> bool:
    return _STOP.is_set()


def clear_stop() -> None:
    """A new command starts (``gpcnav.cli.main``, called again in one process)."""
    _STOP.clear()


def cache_dir() -> Path:
    """Where gpcnav keeps what it makes once and reuses (compiled NLPs, finished episodes):
    ``$GPCNAV_CACHE_DIR`` or ``~/.cache/gpcnav``. Here, not with the solvers, so that the
    deployed network's commands ask it without CasADi."""
    return Path(os.environ.get("GPCNAV_CACHE_DIR") or Path.home() / ".cache" / "gpcnav")


def json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def _host() -> str:
    return hashlib.sha256(socket.gethostname().encode()).hexdigest()[:8]


_WRITER = re.compile(r"\.([0-9a-f]{8})-([0-9]+)\.[a-z0-9_]+")


def writer_tag() -> str:
    """``.HOST-PID``: what a temporary's name holds so that :func:`abandoned` can tell whether
    its writer still runs (``tempfile``'s random part follows it after a dot)."""
    return f".{_host()}-{os.getpid()}"


def abandoned(tmp) -> bool:
    """Whether the temporary file ``tmp`` (named by :func:`atomic_file`) was left by a writer
    that can no longer finish it: a process of this machine that no longer runs (killed
    mid-write). A temporary of another machine, or of a name this module did not make, is
    never called abandoned: its writer may be running."""
    found = _WRITER.findall(Path(tmp).name)
    if not found or found[-1][0] != _host():
        return False
    pid = int(found[-1][1])
    if pid == os.getpid():
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    except OSError:  # it runs, as another user
        return False
    return False


def sweep_abandoned(folder, pattern: str) -> int:
    """Remove what matches ``pattern`` in ``folder`` and :func:`abandoned` says a killed
    writer left (files, or folders with what they hold); returns how many. Nothing a running
    writer, or another machine's, may still use is touched."""
    gone = 0
    try:
        found = list(Path(folder).glob(pattern))
    except OSError:
        return 0
    for stale in found:
        if not abandoned(stale):
            continue
        try:
            if stale.is_dir() and not stale.is_symlink():
                shutil.rmtree(stale)
            else:
                stale.unlink()
            gone += 1
        except OSError:
            pass  # gone already, or not ours to remove
    return gone


NAME_MAX = 255
"""The longest file name, in bytes, of the common file systems (ext4, XFS, Btrfs, APFS, NTFS)."""


def _temporary_stem(name: str, extra: int) -> str:
    """``name`` cut so that a temporary named ``.{stem}{extra bytes}`` fits :data:`NAME_MAX`:
    a file name of 215 to 255 bytes is a valid output, and its temporary, 40 bytes longer, was
    not (``OSError: File name too long`` after the whole run, until 2026-12-01)."""
    room = NAME_MAX - 1 - extra
    raw = name.encode()
    return name if len(raw) <= room else raw[:max(room, 1)].decode(errors="ignore")


@contextlib.contextmanager
def atomic_file(path, suffix: str = ""):
    """Yield a temporary path beside ``path``; on a clean exit it is synced to disk and
    renamed over ``path`` (with ordinary permissions), otherwise removed. The temporary's name
    says which machine and process writes it (:func:`abandoned`)."""
    if _STOP.is_set():
        raise KeyboardInterrupt(f"stopping: {Path(path).name} not written")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    suffix = suffix or path.suffix
    stem = _temporary_stem(path.name, len(writer_tag()) + len(suffix.encode()) + 12)
    sweep_abandoned(path.parent, f".{glob_escape(stem)}.*")  # a kill -9 mid-write's, of this file
    fd, tmp = tempfile.mkstemp(prefix=f".{stem}{writer_tag()}.", suffix=suffix, dir=path.parent)
    os.close(fd)
    tmp = Path(tmp)
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it private; the result is an ordinary file
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_bytes(path, data: bytes) -> None:
    with atomic_file(path) as tmp:
        tmp.write_bytes(data)


def write_text(path, text: str) -> None:
    with atomic_file(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_json(path, doc) -> str:
    """Write ``doc`` as JSON; returns the text written."""
    text = json.dumps(doc, indent=1, default=json_default, allow_nan=False) + "\n"
    write_text(path, text)
    return text


def save_figure(fig, path, **kw) -> None:
    with atomic_file(path) as tmp:
        fig.savefig(tmp, **kw)
