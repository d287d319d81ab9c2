"""The last bad inputs of issue 33 end in one line on stderr and exit status 2, within
seconds, before any episode runs, and leave nothing behind: outputs that cannot be written
(``/proc/x.png``), a Ray cluster that is not there, settings that would make a run absurdly
long. And nothing looks hung: ``--help`` shows every option's default, a compile says so."""
from __future__ import annotations

import argparse
import os
import socket
import subprocess
import sys
import time

import pytest

from conftest import PAPER_DIR, REPO

SCENE = PAPER_DIR / "fig7_1_head_on.toml"


def _free_port() -> int:
    """A port of 127.0.0.1 where nothing listens (bound, then released)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


FREE = _free_port()
CASES = [
    (["simulate", SCENE, "--plot", "/proc/x.png"], "--plot /proc/x.png"),
    (["simulate", SCENE, "--animate", "/proc/x.gif"], "--animate /proc/x.gif"),
    (["simulate", SCENE, "--out", "/proc/run.json"], "--out /proc/run.json"),
    (["simulate", SCENE, "--horizon", "5000"], "--horizon must be at most 24"),
    (["simulate", SCENE, "--sample-time", "1e-6"], "--sample-time must be at least"),
    (["evaluate", "--suite", "random", "--count", "2", "--backend", "ray", "--address", "127.0.0.1:1"],
     "no Ray cluster at 127.0.0.1:1"),
    (["evaluate", "--suite", "random", "--count", "2", "--backend", "ray", "--address", f"127.0.0.1:{FREE}",
      "--out", "{tmp}/out/E.json"], f"no Ray cluster at 127.0.0.1:{FREE}"),
    (["compare", "--suite", "random", "--count", "2", "--controllers", "orca,hrvo", "--backend", "ray",
      "--address", f"ray://127.0.0.1:{FREE}", "--out", "{tmp}/out/C.json"], "no Ray cluster"),
    (["dataset", "--out", "{tmp}/ds", "--samples", "10", "--backend", "ray", "--address", "127.0.0.1:1"],
     "no Ray cluster at 127.0.0.1:1"),
    (["dataset", "--out", "{tmp}/ds", "--samples", "10", "--backend", "ray", "--address", f"127.0.0.1:{FREE}"],
     "no Ray cluster"),
    (["dataset", "--out", "{tmp}/ds", "--samples", "10000000000"], "--samples must be at most"),
    (["evaluate", "--suite", "random", "--count", "2", "--controller", "orca", "--out", "/proc/E.json"],
     "--out /proc/E.json"),
    (["compare", "--suite", "random", "--count", "2", "--controllers", "orca,hrvo", "--out", "/proc/C.json"],
     "--out /proc/C.json"),
    (["compare", "--suite", "random", "--count", "2", "--controllers", "orca,hrvo", "--out", "{tmp}/C.png"],
     "would overwrite it"),
    (["evaluate", "--suite", "random", "--count", "1000000"], "--count must be at most"),
    (["evaluate", "--suite", "circle-crossing", "--movers", "60", "--count", "2"], "cannot place 60 movers"),
    (["simulate", SCENE, "--plot", "{tmp}/out/r.txt"], "matplotlib does not write .txt figures"),
    (["simulate", SCENE, "--plot", "{tmp}/out/r"], "takes a figure's format from its extension"),
    (["bench", "--plot", "{tmp}/out/b.toml"], "matplotlib does not write .toml figures"),
    (["simulate", SCENE, "--animate", "{tmp}/out/a.mp4"], "an animation is written as a GIF"),
    (["simulate", SCENE, "--out", "{tmp}/out/r.json", "--plot", "{tmp}/out/r.json"], "one file for two outputs"),
    # taken and ignored where the suite has its own movers (random --movers 3 ran one mover)
    (["evaluate", "--suite", "random", "--count", "2", "--movers", "3"], "--movers: suite random has its own movers"),
    (["compare", "--suite", "ucy", "--count", "2", "--movers", "3"], "--movers: suite ucy has its own movers"),
    (["evaluate", "--suite", "encounters", "--count", "2", "--behaviour", "orca"],
     "--behaviour: suite encounters has its own movers"),
    # a suite's options with scenario files: taken and ignored (one episode, the EVAL's seed null)
    (["evaluate", SCENE, "--count", "5", "--seed", "5", "--controller", "orca"], "--count, --seed: choose a suite's"),
    (["compare", SCENE, "--movers", "3", "--controllers", "orca,hrvo"], "--movers: chooses a suite's episodes"),
    (["evaluate", SCENE, "--behaviour", "orca", "--controller", "orca"], "give it with --suite"),
    # found only after the work, as tracebacks
    (["train", "{tmp}/no-data", "--out", "/proc/mm", "--preset", "paper"], "--out /proc/mm: cannot write files"),
    (["export", "{tmp}/no-model", "--out", "/proc/x.onnx"], "--out /proc/x.onnx"),
    # a folder that exists and takes no file: its first file's traceback (until 2026-12-01)
    (["import-tracks", REPO / "scenarios/recordings/crowds_zara01.txt.gz", "--max-cases", "1", "--out", "/proc"],
     "--out /proc: cannot write files in /proc"),
    (["dataset", "--samples", "10", "--out", "/proc"], "--out /proc: cannot write files in /proc"),
]


@pytest.mark.parametrize("argv, words", CASES, ids=[" ".join(map(str, a[:1] + a[-2:])) for a, _ in CASES])
def test_refused_in_one_line_within_seconds_leaving_nothing(argv, words, tmp_path):
    argv = [str(a).format(tmp=tmp_path) for a in argv]
    work = tmp_path / "cwd"
    work.mkdir()
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "gpcnav", *argv], capture_output=True, text=True, timeout=60,
                          cwd=work, env={**os.environ, "PYTHONPATH": str(REPO)})
    elapsed = time.monotonic() - t0
    assert proc.returncode == 2, proc.stderr[-2000:]
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"gpcnav {argv[0]}: error: ") and words in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr and not proc.stdout
    assert elapsed < 30
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cwd"] and not list(work.iterdir())  # nothing left


def test_every_option_shows_its_default_in_help():
    """``--help`` of every subcommand shows each option's default (or names it in words),
    so that ``--suite random`` is seen to run 100 episodes."""
    from gpcnav.cli import DefaultsFormatter, build_parser
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    missing = []
    for name, p in sub.choices.items():
        assert p.formatter_class is DefaultsFormatter
        formatter = p._get_formatter()
        for a in p._actions:
            if a.option_strings and not isinstance(a, argparse._HelpAction) and not a.required:
                if "default" not in formatter._get_help_string(a).lower():
                    missing.append((name, a.option_strings[0]))
    assert not missing
    help_text = sub.choices["evaluate"].format_help()
    assert "(default: 100)" in " ".join(help_text.split())  # --count


def test_a_compile_says_so_in_one_line_and_a_cached_library_is_silent(tmp_path, monkeypatch, capsys):
    ca = pytest.importorskip("casadi")
    from casadi_gpc.solvers import compiling
    if compiling.c_compiler() is None:
        pytest.skip("no C compiler")
    monkeypatch.setenv("GPCNAV_CACHE_DIR", str(tmp_path))
    x = ca.SX.sym("x", 2)
    nlp = {"x": x, "p": ca.SX.sym("p", 0), "f": ca.sumsqr(x - 1), "g": ca.SX(0, 1)}
    solver = ca.nlpsol("tiny", "ipopt", nlp, {"print_time": False, "ipopt.print_level": 0})
    lib, _ = compiling.compiled_library(solver, "ipopt", nlp)
    assert lib is not None
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("gpcnav: compiling the planner's NLP (ipopt) to C with ")
    assert str(tmp_path) in lines[0] and "GPCNAV_CACHE_DIR" in lines[0] and " done in " in lines[0]
    compiling.compiled_library(solver, "ipopt", nlp)  # the cache: nothing to say
    assert capsys.readouterr().err == ""


# --- the pool's connection check --------------------------------------------------------------------
def test_addresses_are_read_as_ray_writes_them():
    from casadi_gpc.pool import _host_port
    assert _host_port("127.0.0.1:6379") == ("127.0.0.1", 6379)
    assert _host_port("ray://head.example:10001") == ("head.example", 10001)
    assert _host_port("[::1]:6379") == ("::1", 6379)
    assert _host_port("auto") is None and _host_port("local") is None and _host_port("host") is None


def test_an_absent_cluster_is_refused_at_once_and_a_silent_one_after_the_timeout(monkeypatch):
    from casadi_gpc import pool
    t0 = time.monotonic()
    with pytest.raises(pool.ClusterUnavailable, match="no Ray cluster at 127.0.0.1:"):
        pool.check_reachable(f"127.0.0.1:{_free_port()}")
    assert time.monotonic() - t0 < 5

    def silent(address, timeout):  # what an unroutable address does, without sending anything anywhere
        assert timeout == pool.CONNECT_TIMEOUT_S
        raise socket.timeout("timed out")

    monkeypatch.setattr(pool.socket, "create_connection", silent)
    with pytest.raises(pool.ClusterUnavailable, match=r"no answer within 5 s \(\$GPCNAV_RAY_CONNECT_TIMEOUT_S\)"):
        pool.check_reachable("192.0.2.1:6379")


@pytest.mark.parametrize("value", ["abc", "-1", "nan", "0"])
def test_a_connect_timeout_that_is_no_positive_number_is_said_when_a_cluster_is_reached(monkeypatch, value):
    """$GPCNAV_RAY_CONNECT_TIMEOUT_S was read when casadi_gpc.pool was imported: "abc" stopped every
    command (simulate too) with a traceback, and -1 a Ray run with socket's "Timeout value out of range";
    now one line when a cluster's address is checked, the only use of it."""
    from casadi_gpc import pool
    monkeypatch.setenv("GPCNAV_RAY_CONNECT_TIMEOUT_S", value)  # (read when the run reaches for a cluster)
    with pytest.raises(pool.ClusterUnavailable, match=r"^\$GPCNAV_RAY_CONNECT_TIMEOUT_S must be a positive number"):
        pool.check_reachable("127.0.0.1:6379")
    monkeypatch.setenv("GPCNAV_RAY_CONNECT_TIMEOUT_S", "2.5")
    assert pool.connect_timeout_s() == 2.5


def test_a_reachable_port_passes_the_check():
    from casadi_gpc.pool import check_reachable
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        check_reachable(f"127.0.0.1:{s.getsockname()[1]}")


@pytest.mark.parametrize("command", ["evaluate", "compare"])
def test_a_network_for_another_robot_than_one_file_s_is_refused_before_any_episode(command, tmp_path):
    """The network is checked against the robot of every file, not the first one's alone: it
    was refused only when the second file's episode came, after the planner's compile."""
    text = SCENE.read_text()
    other = text.replace("[robot]\n", "[robot]\nradius_m = 0.22\nwheel_base_m = 0.35\n", 1)
    assert other != text
    (tmp_path / "other.toml").write_text(other.replace('name = "fig7_1_head_on"', 'name = "other_robot"'))
    ctl = ["--controller", "nn"] if command == "evaluate" else ["--controllers", "gpc,nn"]
    t0 = time.monotonic()
    proc = subprocess.run([sys.executable, "-m", "gpcnav", command, str(SCENE), str(tmp_path / "other.toml"), *ctl,
                           "--out", str(tmp_path / "OUT.json")], capture_output=True, text=True, timeout=120,
                          cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert proc.returncode == 2, proc.stderr[-2000:]
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "another robot" in lines[0] and "other.toml" in lines[0], proc.stderr
    assert time.monotonic() - t0 < 30 and sorted(p.name for p in tmp_path.iterdir()) == ["other.toml"]


def test_the_first_of_several_files_whose_robot_the_network_refuses_is_named(tmp_path):
    """The first file's robot was refused without the file's name (the second's with it)."""
    from gpcnav.errors import UsageError
    from casadi_gpc.config import preset
    from gpcnav.controllers import ControllerSpec, check_scenarios
    from scenarios import load_scenario
    other = tmp_path / "other.toml"
    other.write_text(SCENE.read_text().replace("[robot]\n", "[robot]\nradius_m = 0.4\n", 1))
    spec, config = ControllerSpec("nn"), preset("improved")
    with pytest.raises(UsageError, match=r"another robot.*\(the robot of .*other\.toml\)$"):
        check_scenarios(spec, config, [load_scenario(other), load_scenario(SCENE)])
    with pytest.raises(UsageError, match=r"another robot") as one:
        check_scenarios(spec, config, [load_scenario(other)])
    assert "the robot of" not in str(one.value)            # one file: its own command names it



@pytest.mark.parametrize("command", ["simulate", "evaluate", "compare"])
def test_an_output_that_is_the_scenario_file_is_refused_and_the_file_kept(command, tmp_path):
    """``--out`` naming the scenario file itself replaced the user's file by the run's JSON."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.read_text())
    ctl = ["--controllers", "blind,stand"] if command == "compare" else ["--controller", "blind"]
    for out in ("scene.toml", "./scene.toml", str(scene)):
        proc = subprocess.run([sys.executable, "-m", "gpcnav", command, "scene.toml", *ctl, "--out", out],
                              capture_output=True, text=True, timeout=120, cwd=tmp_path,
                              env={**os.environ, "PYTHONPATH": str(REPO)})
        assert proc.returncode == 2, proc.stderr[-2000:]
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and "is the scenario file" in lines[0], proc.stderr
        assert scene.read_text() == SCENE.read_text() and sorted(p.name for p in tmp_path.iterdir()) == ["scene.toml"]
    if command == "compare":  # the table beside --out would be the scenario
        md = tmp_path / "scene.md"
        md.write_text(SCENE.read_text())
        proc = subprocess.run([sys.executable, "-m", "gpcnav", command, "scene.md", *ctl, "--out", "scene.json"],
                              capture_output=True, text=True, timeout=120, cwd=tmp_path,
                              env={**os.environ, "PYTHONPATH": str(REPO)})
        assert proc.returncode == 2 and "is one of the scenario files" in proc.stderr, proc.stderr
        assert md.read_text() == SCENE.read_text()


@pytest.mark.parametrize("command", ["simulate", "evaluate", "compare", "bench"])
def test_an_output_that_is_the_model_file_or_bench_s_scenario_is_refused_and_the_file_kept(command, tmp_path):
    """``--out M.onnx`` with ``--model M.onnx`` wrote the run's JSON over the model it had run (exit 0;
    evaluate, compare and bench then failed on the model at their next run), and bench's ``--out``
    was not checked against its scenario file."""
    from nn_export.runtime.policy import shipped_model_path
    model = tmp_path / "m.onnx"
    model.write_bytes(shipped_model_path("improved").read_bytes())
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE.read_text())
    ctl = {"compare": ["--controllers", "nn,stand"], "bench": ["--solvers", "sqpmethod-daqp+fatrop"]}.get(
        command, ["--controller", "nn"])
    outs = [("m.onnx", "is the model file")] + [("scene.toml", "is the scenario file")] * (command == "bench")
    for out, words in outs:
        proc = subprocess.run([sys.executable, "-m", "gpcnav", command, "scene.toml", *ctl, "--model", "m.onnx",
                               "--out", out], capture_output=True, text=True, timeout=120, cwd=tmp_path,
                              env={**os.environ, "PYTHONPATH": str(REPO)})
        assert proc.returncode == 2, proc.stderr[-2000:]
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and f"--out {out} {words}" in lines[0], proc.stderr
    assert model.read_bytes() == shipped_model_path("improved").read_bytes()
    assert scene.read_text() == SCENE.read_text()


def test_bench_on_a_scene_shorter_than_one_sample_is_refused_before_any_work(tmp_path):
    """It recorded no problem and stopped on a division by zero after building every solver."""
    short = tmp_path / "short.toml"
    short.write_text(SCENE.read_text().replace("duration_s = ", "duration_s = 0.1 #", 1))
    proc = subprocess.run([sys.executable, "-m", "gpcnav", "bench", str(short), "--solvers", "sqpmethod-daqp+fatrop",
                           "--out", str(tmp_path / "B.json")], capture_output=True, text=True, timeout=120,
                          cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert proc.returncode == 2, proc.stderr[-2000:]
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "shorter than one sample" in lines[0] and not (tmp_path / "B.json").exists()



def test_train_into_a_file_and_export_into_a_folder_are_refused_before_any_work(tmp_path):
    """Both ran the whole job and then stopped with a traceback (FileExistsError, IsADirectoryError)."""
    (tmp_path / "afile").write_text("mine")
    (tmp_path / "adir").mkdir()
    for argv, words in ((["train", "no-data", "--out", "afile", "--preset", "paper"], "a file, where the trained model"),
                        (["export", "no-model", "--out", "adir"], "is a folder")):
        proc = subprocess.run([sys.executable, "-m", "gpcnav", *argv], capture_output=True, text=True, timeout=120,
                              cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(REPO)})
        assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and words in proc.stderr, proc.stderr
    assert (tmp_path / "afile").read_text() == "mine" and not list((tmp_path / "adir").iterdir())


@pytest.mark.parametrize("argv", [["export", "no-model"], ["simulate", str(SCENE), "--controller", "blind"],
                                  pytest.param(["compare", str(SCENE), "--controllers", "blind,stand"],
                                               marks=pytest.mark.slow)])  # 7 s: kept out of the default suite
def test_an_output_that_is_a_pipe_or_a_link_to_one_is_refused_and_kept(argv, tmp_path):
    """Outputs are renamed over their path: ``--out /dev/full`` (as root) replaced the device
    with the model file, exit 0; a link to a pipe (``/dev/stdout``) was replaced by a file."""
    os.mkfifo(tmp_path / "pipe")
    (tmp_path / "link").symlink_to(tmp_path / "pipe")
    outs = ["pipe", "link"] if argv[0] != "compare" else ["pipe", "link", "c.json"]
    if argv[0] == "compare":  # the table beside --out
        os.symlink(tmp_path / "pipe", tmp_path / "c.md")
    for out in outs:
        proc = subprocess.run([sys.executable, "-m", "gpcnav", *argv, "--out", out], capture_output=True, text=True,
                              timeout=120, cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(REPO)})
        assert proc.returncode == 2, proc.stderr[-2000:]
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and "is not a regular file" in lines[0], proc.stderr
    assert (tmp_path / "pipe").is_fifo() and (tmp_path / "link").is_symlink()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["pipe", "link"] + (["c.md"] if argv[0] == "compare" else []))


def test_names_longer_than_a_file_system_takes_are_one_line_and_the_longest_it_takes_are_written(tmp_path, capsys):
    """A file name of 215 to 255 bytes is valid, and its temporary (40 bytes longer) was not: the
    output failed after the whole run with 'OSError: File name too long'. A name over 255 bytes
    was the checks' OSError traceback, before the run (until 2026-12-01)."""
    from gpcnav.cli import main
    from scenarios.recordings import recording_name
    longest = "r" * 250 + ".json"                                  # 255 bytes
    assert main(["simulate", str(SCENE), "--controller", "blind", "--out", str(tmp_path / longest)]) == 0
    assert (tmp_path / longest).is_file() and [p.name for p in tmp_path.iterdir()] == [longest]
    too_long = str(tmp_path / ("r" * 300))
    capsys.readouterr()
    for argv in (["simulate", str(SCENE), "--controller", "blind", "--out", too_long + ".json"],
                 ["simulate", str(SCENE), "--controller", "blind", "--plot", too_long + "/x.png"],
                 ["compare", str(SCENE), "--controllers", "blind,stand", "--out", too_long + ".json"],
                 ["import-tracks", str(SCENE), "--out", too_long],
                 ["dataset", "--out", too_long, "--samples", "10"],
                 ["train", str(tmp_path), "--out", too_long]):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and "bytes long, more than the 255" in err, (argv, err)
    assert [p.name for p in tmp_path.iterdir()] == [longest]
    # a recording's name is cut to 200 characters: its cases' names fit
    assert recording_name("a" * 240 + ".txt") == "a" * 200


def test_evaluate_and_compare_keep_their_episodes_beside_an_out_of_the_longest_name(tmp_path, capsys):
    """The finished episodes' folder is --out's name and '.episodes': for an --out of 247 to 255
    bytes, a name no file system takes (its OSError traceback before the run); the table beside
    a compare's --out with no extension, 256 bytes."""
    from gpcnav.cli import main
    out = tmp_path / ("e" * 250 + ".json")
    argv = ["evaluate", str(SCENE), "--controller", "blind", "--workers", "1", "--out", str(out), "--keep-episodes"]
    assert main(argv) == 0 and out.is_file()
    (kept,) = [p for p in tmp_path.iterdir() if p.name.endswith(".episodes")]
    assert len(kept.name.encode()) <= 255 and any(kept.iterdir())
    capsys.readouterr()
    assert main(argv) == 0 and "reused 1 of 1" in capsys.readouterr().err             # the same folder, found again
    bare = str(tmp_path / ("c" * 253))
    assert main(["compare", str(SCENE), "--controllers", "blind,stand", "--workers", "1", "--out", bare]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "the table beside it" in err and "256 bytes long" in err, err
