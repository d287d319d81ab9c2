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

import pytest

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


SLOW_MODULE = """
import os, time
from casadi_gpc import ControlDecision

class Slow:
    sample_time_s = 0.5

    def reset(self):
        pass

    def decide(self, observation):
        open(f"busy-{os.getpid()}", "w").close()
        time.sleep(3.0)
        return ControlDecision(v_right_mps=0.2, v_left_mps=0.2)
"""


def test_a_stop_while_the_workers_are_busy_ends_at_once(tmp_path):
    """The stop waited for the workers to finish their tasks, and the stop's signal, sent again
    every second, broke that wait off: the command said its line, then hung for ever at its exit
    on workers that never got their end (a SIGTERM'd evaluate, beside two busy loops, 3 runs in
    3). Now the workers are ended at once."""
    (tmp_path / "slow.py").write_text(SLOW_MODULE, encoding="utf-8")
    text = (REPO / "scenarios" / "paper" / "fig7_1_head_on.toml").read_text(encoding="utf-8")
    files = []
    for k in range(4):
        (tmp_path / f"s{k}.toml").write_text(text, encoding="utf-8")
        files.append(f"s{k}.toml")
    proc = _start(["evaluate", *files, "--controller", "slow:Slow", "--workers", "2", "--out", "E.json"], tmp_path)
    _wait_for(lambda: len(list(tmp_path.glob("busy-*"))) >= 2, proc)  # both workers inside a 3 s decision
    workers = _children(proc.pid)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 143, err
    assert err.strip().splitlines()[-1] == "gpcnav evaluate: terminated; what finished is kept: the same command resumes"
    assert time.monotonic() - t0 < 2.5  # not the workers' 3 s decisions waited for
    time.sleep(0.5)
    assert not [w for w in workers if Path(f"/proc/{w}").exists()
                and Path(f"/proc/{w}/stat").read_text().split()[2] != "Z"]


def test_a_compile_stopped_by_sigterm_leaves_no_temporary_folder(tmp_path):
    """A planner setting never compiled before (its own cache key), SIGTERM just after the
    compile's folder is made: while CasADi generates the code, where an exception raised by the
    handler was lost (the command ran on to its end, exit 0), or while gcc runs."""
    cache = tmp_path / "cache"
    argv = ["simulate", REPO / "scenarios" / "paper" / "fig7_1_head_on.toml", "--controller", "gpc",
            "--set", "clearance_margin_m=0.2173"]
    proc = _start(argv, tmp_path, {"GPCNAV_CACHE_DIR": str(cache)})
    _wait_for(lambda: any(p.is_dir() and p.name.startswith(".build") for p in cache.glob("*")), proc)
    time.sleep(0.2)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 143, err
    assert err.strip().splitlines()[-1] == "gpcnav simulate: terminated", err
    assert not [p for p in cache.rglob(".build*") if p.is_dir()], sorted(cache.rglob("*"))


def test_after_a_stop_nothing_more_is_written(tmp_path):
    """Once a stop is asked (Ctrl-C, SIGTERM), no file is written: an episode finished after it,
    its solve broken by the interrupt and taken for a failed one, was kept with changed numbers
    and reused by the resumed run (found by an audit). A new command writes again."""
    from casadi_gpc.io import clear_stop, request_stop, write_text
    write_text(tmp_path / "a.json", "{}")
    request_stop()
    try:
        try:
            write_text(tmp_path / "b.json", "{}")
            raise AssertionError("written after the stop")
        except KeyboardInterrupt:
            pass
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]  # no temporary either
    finally:
        clear_stop()
    write_text(tmp_path / "b.json", "{}")


_STOP_INSIDE = """
import signal, sys
from gpcnav import cli
def run(args):
    try:
        cli._stop(getattr(signal, sys.argv[1]), None)  # as the signal arrives inside a C library's call back
    except KeyboardInterrupt as exc:
        raise SystemError("<built-in function _function_buffer_eval> returned a result with an exception set") from exc
cli.importlib.import_module("gpcnav.commands.evaluate").run = run
sys.exit(cli.main(["evaluate", "--suite", "random", "--count", "1", "--controller", "orca"]))
"""


def test_a_stop_that_comes_out_as_a_librarys_error_is_a_stop(tmp_path):
    """SIGINT or SIGTERM inside CasADi's call back into Python came out as a SystemError chained
    to it: a traceback, exit 1 (found by an audit). It is the stop it is: one line, 130 or 143."""
    for sig, code, what in (("SIGINT", 130, "interrupted"), ("SIGTERM", 143, "terminated")):
        got = subprocess.run([sys.executable, "-c", _STOP_INSIDE, sig], cwd=tmp_path, capture_output=True, text=True,
                             timeout=120, env={**os.environ, "PYTHONPATH": str(REPO)})
        assert got.returncode == code, got.stderr
        assert got.stderr.strip() == f"gpcnav evaluate: {what}; what finished is kept: the same command resumes", \
            got.stderr


@pytest.mark.slow
def test_ctrl_c_during_solves_always_stops_and_the_resumed_run_is_the_uninterrupted_one(tmp_path):
    """Ctrl-C with one worker, the planner solving in the main process: 1 run in 5 went on to its
    end, exit 0, one episode's numbers changed by the broken solve (found by an audit). Stopped
    at four moments, every run says so and exits 130, and the run resumed after them writes the
    document an uninterrupted run writes."""
    import json
    argv = ["evaluate", "--suite", "circle-crossing", "--movers", "5", "--count", "10", "--seed", "901", "--controller",
            "gpc", "--workers", "1", "--out", "E.json"]
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    whole = tmp_path / "whole"
    whole.mkdir()
    assert subprocess.run([sys.executable, "-m", "gpcnav", *argv], cwd=whole, capture_output=True, text=True,
                          timeout=900, env=env).returncode == 0
    store = tmp_path / "E.json.episodes"
    stopped = 0
    for delay in (0.3, 0.9, 1.7, 2.6):
        proc = _start(argv, tmp_path)
        before = len(list(store.glob("[0-9a-f]*.json")))
        deadline = time.monotonic() + 240
        while len(list(store.glob("[0-9a-f]*.json"))) <= before and proc.poll() is None:
            assert time.monotonic() < deadline
            time.sleep(0.05)
        time.sleep(delay)
        alive = proc.poll() is None
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
        if not alive:
            assert proc.returncode == 0, err
            break  # finished before the signal: nothing left to stop (a run alive at it must stop)
        if proc.returncode == -signal.SIGINT and "interrupted" not in err and (tmp_path / "E.json").is_file():
            break  # it finished as the signal came: the signal met the interpreter ending, its document written
        stopped += 1
        assert proc.returncode == 130 and "Traceback" not in err, err
        assert err.strip().splitlines()[-1] == "gpcnav evaluate: interrupted; what finished is kept: the same " \
            "command resumes", err
    else:
        assert subprocess.run([sys.executable, "-m", "gpcnav", *argv], cwd=tmp_path, capture_output=True, text=True,
                              timeout=900, env=env).returncode == 0
    assert stopped >= 2  # stopped at least twice, or nothing was tested
    keys = ("scenario", "outcome", "steps", "min_clearance_m", "path_length_m", "tracking_rmse_m", "interventions")
    got, want = (json.loads((d / "E.json").read_text())["episodes_detail"] for d in (tmp_path, whole))
    assert [[e[k] for k in keys] for e in got] == [[e[k] for k in keys] for e in want]


def test_a_stopped_on_policy_round_and_a_full_disk_say_so_in_one_line(tmp_path, monkeypatch, capsys):
    """A ``dataset --dagger`` round stopped part-way keeps nothing (it is written whole): the
    line said "what finished is kept" (found by an audit); a full disk was a traceback."""
    import errno
    from gpcnav import cli
    module = cli.importlib.import_module("gpcnav.commands.dataset")

    def interrupted(args):
        raise KeyboardInterrupt

    monkeypatch.setattr(module, "run", interrupted)
    argv = ["dataset", "--out", str(tmp_path / "D"), "--dagger", "gpc", "--round", "1", "--suite", "random"]
    assert cli.main(argv) == 130
    assert capsys.readouterr().err.strip() == ("gpcnav dataset: interrupted; an on-policy round is kept only whole: "
                                               "the same command runs it again")
    assert cli.main(["dataset", "--out", str(tmp_path / "D"), "--samples", "10"]) == 130
    assert capsys.readouterr().err.strip() == ("gpcnav dataset: interrupted; what finished is kept: the same command "
                                               "resumes")

    def full(args):
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "E.json"))

    monkeypatch.setattr(module, "run", full)
    assert cli.main(argv) == 1
    assert capsys.readouterr().err.strip() == f"gpcnav dataset: error: No space left on device: {tmp_path / 'E.json'}"


def test_a_signal_that_comes_again_while_the_stop_is_handled_is_still_one_line(monkeypatch, capsys):
    """`timeout` sends SIGTERM to the command and then to its process group: the second landed
    while main() was handling the first (measured: `timeout 60 gpcnav evaluate --suite ucy
    --count 100000`), and the command ended in a traceback of two Terminated where one line
    was promised. Here the second comes, deterministically, while the first is handled."""
    from gpcnav import cli
    from gpcnav.commands import simulate

    def stopped_run(args):
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(5.0)  # (the handler raises Terminated here)
        raise AssertionError("not stopped")

    original = cli._terminated

    def again_while_handled(exc):
        os.kill(os.getpid(), signal.SIGTERM)
        for _ in range(1000):  # bytecodes: where the handler of the second signal runs
            pass
        return original(exc)

    monkeypatch.setattr(simulate, "run", stopped_run)
    monkeypatch.setattr(cli, "_terminated", again_while_handled)
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        code = cli.main(["simulate", str(REPO / "scenarios" / "paper" / "fig7_1_head_on.toml"), "--controller",
                         "stand"])
    finally:
        for sig, handler in previous.items():  # (main() leaves them ignored after a stop)
            signal.signal(sig, handler)
    assert code == 143
    assert capsys.readouterr().err.strip().splitlines() == ["gpcnav simulate: terminated"]


@pytest.mark.parametrize("sig, code, what", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")])
def test_reproduce_stopped_in_a_stage_or_between_stages_says_so_once(sig, code, what, monkeypatch, capsys):
    """``reproduce`` runs its stages as commands through ``main()``. Stopped inside one, the stage
    said its own stop and reproduce "error: stage command failed (exit 130)", exit 2; and once a
    stage had finished, a stop in reproduce's own work (its in-process stages) was taken and not
    raised: the next stage cleared it and the run went on (exit 0)."""
    from gpcnav import cli
    from gpcnav.commands import reproduce, simulate
    paper = str(REPO / "scenarios" / "paper" / "fig7_1_head_on.toml")
    real_simulate = simulate.run

    def stopped_in_a_stage(args):
        reproduce._cli(["simulate", paper, "--controller", "stand"])  # a stage that finishes
        monkeypatch.setattr(simulate, "run", lambda a: os.kill(os.getpid(), sig) or time.sleep(5.0))
        reproduce._cli(["simulate", paper, "--controller", "stand"])  # the stop comes inside this one
        raise AssertionError("not stopped")

    def stopped_between_stages(args):
        reproduce._cli(["simulate", paper, "--controller", "stand"])
        os.kill(os.getpid(), sig)  # in reproduce's own work (the handler raises here)
        reproduce._cli(["simulate", paper, "--controller", "stand"])
        return 0

    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    for fake in (stopped_in_a_stage, stopped_between_stages):
        monkeypatch.setattr(simulate, "run", real_simulate)
        monkeypatch.setattr(reproduce, "run", fake)
        try:
            assert cli.main(["reproduce", "--out", "/tmp/unused-by-the-fake"]) == code, fake.__name__
        finally:
            for s, handler in previous.items():  # (main() leaves them ignored after SIGTERM)
                signal.signal(s, handler)
        captured = capsys.readouterr()
        assert captured.err.strip().splitlines() == [f"gpcnav reproduce: {what}; what finished is kept: the same "
                                                     f"command resumes"], fake.__name__
