"""Failures on Ray said as on local workers: a task's own error raised as itself (it came in Ray's
wrapper, several lines with the remote traceback in colour: ``evaluate --backend ray`` with a
controller whose decide() raised printed them after ``error:``), and a task whose workers die
beyond Ray's retries, or Ray failing under the run (its raylet killed), :class:`~casadi_gpc.pool.WorkersDied`
in one line, exit 1 (they were Ray's ``WorkerCrashedError`` and ``LocalRayletDiedError`` tracebacks,
where local workers say one line: docs/evaluation.md)."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

ray = pytest.importorskip("ray")

from casadi_gpc.pool import WORKER_RESTARTS, WorkerPool, WorkersDied  # noqa: E402
from conftest import REPO  # noqa: E402


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def test_a_task_error_on_ray_is_the_task_own_error(local_ray):
    def task(text):  # (made here: Ray sends it by value, not by this module's name)
        return int(text)

    with pytest.raises(ValueError) as info:
        list(WorkerPool(2, "ray").imap_unordered(task, [("1",), ("x",)]))
    assert type(info.value) is ValueError
    assert str(info.value) == "invalid literal for int() with base 10: 'x'"


def test_a_task_that_kills_its_ray_worker_every_time_is_one_line(local_ray):
    def task():
        os.abort()

    with pytest.raises(WorkersDied) as info:
        list(WorkerPool(2, "ray").imap_unordered(task, [()]))
    text = str(info.value)
    assert "\n" not in text and text.startswith(f"Ray workers died {WORKER_RESTARTS + 1} times running one task")


def test_ray_failing_under_the_run_is_one_line():
    """The local Ray instance's raylet killed mid-run (evaluate --backend ray): Ray's
    LocalRayletDiedError traceback, exit 1; now WorkersDied's one line (what finished is kept)."""
    from types import SimpleNamespace

    from casadi_gpc.pool import _ray_result

    def get(ref):
        raise ray.exceptions.LocalRayletDiedError()

    with pytest.raises(WorkersDied) as info:
        _ray_result(SimpleNamespace(get=get, exceptions=ray.exceptions), None)
    text = str(info.value)
    assert "\n" not in text
    assert text.startswith("Ray failed under the run: LocalRayletDiedError: The task's local raylet")


@pytest.mark.slow
def test_an_evaluation_on_ray_stopped_by_sigterm_says_so(tmp_path):
    """Ray's init put its own SIGTERM handlers in (sys.exit(15); its C++ crash handler, which Ray's
    shutdown leaves at the default action while the stop's repeated signal comes): a SIGTERM'd
    evaluate --backend ray ended with exit status 15 or 143 and no line; now as on local workers."""
    argv = ["evaluate", "--suite", "random", "--count", "200", "--seed", "3", "--controller", "orca", "--workers",
            "2", "--backend", "ray", "--out", "E.json"]
    proc = subprocess.Popen([sys.executable, "-m", "gpcnav", *argv], cwd=tmp_path, text=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            env={**os.environ, "PYTHONPATH": str(REPO)})
    store, deadline = tmp_path / "E.json.episodes", time.monotonic() + 240.0
    while len(list(store.glob("[0-9a-f]*.json"))) < 3:
        assert proc.poll() is None and time.monotonic() < deadline
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err[-2000:]
    assert err.strip().splitlines()[-1] == \
        "gpcnav evaluate: terminated; what finished is kept: the same command resumes", err[-2000:]
