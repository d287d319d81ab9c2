"""Writing outputs whole or not at all: a temporary file in the same folder, flushed to
disk, then renamed over the target. A crash (kill -9 included) leaves the old file or the
new one, never half of one."""
from __future__ import annotations

import contextlib
import json
import os
import tempfile
from pathlib import Path

import numpy as np

__all__ = ["atomic_file", "json_default", "write_json", "write_text", "write_bytes", "save_figure", "cache_dir"]


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


@contextlib.contextmanager
def atomic_file(path, suffix: str = ""):
    """Yield a temporary path beside ``path``; on a clean exit it is synced to disk and
    renamed over ``path`` (with ordinary permissions), otherwise removed."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix or path.suffix, dir=path.parent)
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
