"""SIGTERM (``timeout``, a job scheduler, ``kill``) stops a command as Ctrl-C does: one line on
stderr, exit status 143, the finished episodes kept for the same command to resume, no worker left
running, and no temporary folder of a compile left in the cache."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from conftest import REPO


def _start(argv, cwd: Path, env_extra: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "gpcnav", *map(str, argv)], cwd=cwd, text=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            env={**os.environ, "PYTHONPATH": str(REPO), **(env_extra or {})})


def _wait_for(cond, proc: subprocess.Popen, deadline_s: float = 240.0) -> None:
    deadline = time.monotonic() + deadline_s
    while not cond():
        assert proc.poll() is None, "finished before it could be stopped: make the run longer"
        assert time.monotonic() < deadline
        time.sleep(0.05)


def _children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def test_an_evaluation_stopped_by_sigterm_says_so_and_resumes(tmp_path):
    argv = ["evaluate", "--suite", "random", "--count", "60", "--seed", "3", "--controller", "orca", "--workers", "2",
            "--out", "E.json"]
    store = tmp_path / "E.json.episodes"
    proc = _start(argv, tmp_path)
    _wait_for(lambda: len(list(store.glob("[0-9a-f]*.json"))) >= 3, proc)
    workers = _children(proc.pid)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, err
    lines = err.strip().splitlines()
    assert lines[-1] == "gpcnav evaluate: terminated; what finished is kept: the same command resumes", err
    assert "Traceback" not in err
    time.sleep(0.5)
    assert not [w for w in workers if Path(f"/proc/{w}").exists()
                and Path(f"/proc/{w}/stat").read_text().split()[2] != "Z"]  # no worker left computing
    kept = len(list(store.glob("[0-9a-f]*.json")))
    assert kept >= 3 and not (tmp_path / "E.json").exists()
    again = subprocess.run([sys.executable, "-m", "gpcnav", *argv], cwd=tmp_path, capture_output=True, text=True,
                           timeout=600, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert again.returncode == 0 and f"reused {kept}" in again.stderr and (tmp_path / "E.json").exists()


def test_a_compile_stopped_by_sigterm_leaves_no_temporary_folder(tmp_path):
    """A planner setting never compiled before (its own cache key), SIGTERM just after the
    compile's folder is made: while CasADi generates the code, where an exception raised by the
    handler was lost (the command ran on to its end, exit 0), or while gcc runs."""
    cache = tmp_path / "cache"
    argv = ["simulate", REPO / "scenarios" / "paper" / "fig7_1_head_on.toml", "--controller", "gpc",
            "--set", "clearance_margin_m=0.2173"]
    proc = _start(argv, tmp_path, {"GPCNAV_CACHE_DIR": str(cache)})
    _wait_for(lambda: any(p.is_dir() and p.name.startswith("tmp") for p in cache.glob("*")), proc)
    time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert err.strip().splitlines()[-1] == "gpcnav simulate: terminated", err
    assert not [p for p in cache.rglob("tmp*") if p.is_dir()], sorted(cache.rglob("*"))
