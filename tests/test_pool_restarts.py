"""A local worker that dies abruptly (the kernel's out-of-memory killer, a signal, a crash in
compiled code) ended a run in ``BrokenProcessPool``'s traceback, exit 1, with the tasks of the
other workers lost too. Now the tasks then in flight run again in new workers, said in one line,
up to :data:`~casadi_gpc.pool.WORKER_RESTARTS` times; beyond, one line and exit 1, what finished
kept."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest

from casadi_gpc.pool import WORKER_RESTARTS, WorkerPool, WorkersDied
from conftest import REPO, straight_line_toml


def _dies_once(flag: str, i: int, die_at: int) -> tuple[int, int]:
    """Task ``i``: the worker that runs task ``die_at`` kills itself, the first time only."""
    if i == die_at and not os.path.exists(flag):
        open(flag, "w").close()
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(0.02)
    return i, i * i


def _always_dies(i: int) -> int:
    if i == 2:
        os.kill(os.getpid(), signal.SIGKILL)
    time.sleep(0.02)
    return i


def test_a_worker_killed_once_its_tasks_run_again_and_every_result_comes_once(tmp_path, capfd):
    flag = str(tmp_path / "died")
    results = list(WorkerPool(2).imap_unordered(_dies_once, [(flag, i, 5) for i in range(12)]))
    assert sorted(results) == [(i, i * i) for i in range(12)]
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("worker pool: a worker process died (killed by SIGKILL")
    assert err[0].endswith("then in flight run again in new workers")


def test_a_task_that_kills_every_worker_ends_in_one_error_after_the_restarts(capfd):
    with pytest.raises(WorkersDied, match=rf"^worker processes died {WORKER_RESTARTS + 1} times \(killed by SIGKILL"):
        for _ in WorkerPool(2).imap_unordered(_always_dies, [(i,) for i in range(6)]):
            pass
    assert len(capfd.readouterr().err.strip().splitlines()) == WORKER_RESTARTS


USER_MODULE = textwrap.dedent('''
    import os, signal
    from casadi_gpc import ControlDecision

    class Killer:
        """Drives straight; the worker deciding at 1 s on the line named in $KILL_LINE dies, once
        (a flag file beside it), or every time ($KILL_ALWAYS)."""
        sample_time_s = 0.5

        def reset(self):
            pass

        def decide(self, observation):
            if observation.t_s == 1.0 and observation.reference.end_pose[0] > float(os.environ["KILL_LINE"]):
                if os.environ.get("KILL_ALWAYS") or not os.path.exists("died"):
                    open("died", "w").close()
                    os.kill(os.getpid(), signal.SIGKILL)
            v = observation.reference.speed_mps
            return ControlDecision(v_right_mps=v, v_left_mps=v)
''')


def _evaluate(folder, out: str, **env):
    files = [f"line{k}.toml" for k in range(6)]
    return subprocess.run([sys.executable, "-m", "gpcnav", "evaluate", *files, "--controller", "killer:Killer",
                           "--workers", "2", "--out", out], cwd=folder, capture_output=True, text=True, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(REPO), **env})


@pytest.fixture
def lines(tmp_path):
    (tmp_path / "killer.py").write_text(USER_MODULE, encoding="utf-8")
    for k in range(6):  # lines of 3, 3.5, ... 5.5 m
        (tmp_path / f"line{k}.toml").write_text(straight_line_toml(f"line{k}", 20.0, 3.0 + 0.5 * k), encoding="utf-8")
    return tmp_path


@pytest.mark.slow  # (the pool's own test above and the one below keep the default suite's cover)
def test_an_evaluation_whose_worker_is_killed_gives_the_document_of_one_that_was_not(lines):
    r = _evaluate(lines, "plain.json", KILL_LINE="100")
    assert r.returncode == 0, r.stderr
    r = _evaluate(lines, "killed.json", KILL_LINE="4.2")
    assert r.returncode == 0, r.stderr
    assert (lines / "died").exists() and "worker pool: a worker process died (killed by SIGKILL" in r.stderr
    plain, killed = (json.loads((lines / f).read_text()) for f in ("plain.json", "killed.json"))
    strip = ("compute_median_s",)
    rows = [[{k: v for k, v in d.items() if k not in strip} for d in doc["episodes_detail"]] for doc in (plain, killed)]
    assert rows[0] == rows[1] and len(rows[0]) == 6


def test_an_evaluation_whose_workers_keep_dying_ends_in_one_line_and_keeps_what_finished(lines):
    r = _evaluate(lines, "e.json", KILL_LINE="5.2", KILL_ALWAYS="1")  # only the last line kills its worker
    assert r.returncode == 1
    err = r.stderr.strip().splitlines()
    assert err[-1].startswith(f"gpcnav evaluate: error: worker processes died {WORKER_RESTARTS + 1} times (killed by "
                              f"SIGKILL") and err[-1].endswith("what finished is kept: the same command resumes")
    assert "Traceback" not in r.stderr and not (lines / "e.json").exists()
    kept = {json.loads(p.read_text())["scenario"] for p in (lines / "e.json.episodes").glob("*.json")}
    assert kept == {f"line{k}" for k in range(5)}
