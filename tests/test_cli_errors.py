"""Bad command-line input a new user tries ends in one line on stderr and exit status 2,
not a traceback, and before any work."""
from __future__ import annotations

import subprocess
import sys

import pytest

from conftest import PAPER_DIR


def _gpcnav(*argv, timeout=120):
    return subprocess.run([sys.executable, "-m", "gpcnav", *map(str, argv)], capture_output=True, text=True,
                          timeout=timeout)


@pytest.fixture
def a_file(tmp_path):
    """A regular file, under which no folder can be made."""
    path = tmp_path / "notes.txt"
    path.write_text("a file, not a folder\n")
    return path


@pytest.mark.parametrize("argv, words", [
    (["simulate", PAPER_DIR / "fig7_1_head_on.toml", "--out", "{file}/runs/run.json"], "--out"),
    (["simulate", PAPER_DIR / "fig7_1_head_on.toml", "--plot", "{file}/fig.png"], "--plot"),
    (["reproduce", "--quick", "--out", "{file}/out"], "--out"),
    (["reproduce", "--quick", "--out", "{file}"], "--out"),
    (["evaluate", "--suite", "random", "--count", "2", "--seed", "-1"], "--seed"),
    (["simulate", PAPER_DIR / "fig7_1_head_on.toml", "--seed", "-1"], "--seed"),
    (["dataset", "--out", "{tmp}/ds", "--samples", "4", "--seed", "-1"], "--seed"),
    (["train", "{tmp}", "--out", "{tmp}/model", "--cost-gap-weight", "0"], "--cost-gap-weight"),
])
def test_bad_input_is_one_line_and_exit_2(argv, words, a_file, tmp_path):
    argv = [str(a).format(file=a_file, tmp=tmp_path) for a in argv]
    proc = _gpcnav(*argv)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"gpcnav {argv[0]}: error: ") and words in lines[0], proc.stderr
    assert "Traceback" not in proc.stderr and not proc.stdout
    assert a_file.read_text() == "a file, not a folder\n"


def test_help_points_to_files_the_project_has(capsys):
    """The help names the README and docs/, never a file a user of the project lacks (each
    command's help in this process, the top one as a user runs it)."""
    from pathlib import Path
    from gpcnav.cli import main
    repo = Path(__file__).resolve().parents[1]
    for command in ("simulate", "evaluate", "dataset", "train", "export", "bench", "reproduce"):
        with pytest.raises(SystemExit) as done:
            main([command, "--help"])
        assert done.value.code == 0
        out = capsys.readouterr().out
        assert command in out and "CONTRACT" not in out, command
    proc = _gpcnav("--help")
    assert proc.returncode == 0 and "CONTRACT" not in proc.stdout
    top = proc.stdout
    assert "README" in top and "docs/" in top
    assert (repo / "README.md").is_file() and (repo / "docs").is_dir()
