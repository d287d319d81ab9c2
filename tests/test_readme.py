"""The README as a new user follows it: every ```bash and ```python block runs as written,
from a fresh copy of the checkout (its tracked and untracked, not ignored, files in a temporary
folder, the folder the README's commands run from).

- Each ```python block runs alone (``python -c`` in the copy's root). Where the block ends with
  a ``# prints:`` comment, what it prints must be those lines exactly.
- A ```python block that the README says to "Save this as `FILE`" is written there first.
- The ```bash blocks run line by line, in order, in one shell each (a later line may use what an
  earlier one wrote). A line must exit 0. Its output is read: a trailing comment that starts
  with an outcome (``# reached_goal``, ``# collided``, ``# timed_out``) must be the episode's
  outcome that ``simulate`` prints; ``--out`` files are parsed and checked (RUN, EVAL and
  COMPARE documents, a dataset's manifest, a model file); ``--plot`` must be a PNG.
- Short versions where a run is long: ``--count N`` runs 2 episodes, ``--samples N`` labels 200
  situations, ``gpcnav train`` stops after 5 epochs. ``gpcnav bench`` and ``gpcnav reproduce``
  run only in the slow test (``pytest -m slow``).
- The two set-up commands create virtual environments and are not run here: the second must be
  the line ``.ci/run`` runs, the first the one the project has always shown; the slow test runs
  the first one's ``gpcnav reproduce --quick`` as written.

Also held: the README stays under 200 lines, names no internal model (``d21``, ``m6``, ...),
calls the check layer by that one name in its prose, and every project path it names exists.
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import REPO, check_run_document

README = REPO / "README.md"
TEXT = README.read_text(encoding="utf-8")
FENCE = re.compile(r"^```(\w*)\n(.*?)^```[ \t]*$", re.M | re.S)
OUTCOMES = ("reached_goal", "collided", "timed_out")
SLOW_COMMANDS = ("gpcnav bench", "gpcnav reproduce")
SETUP_FIRST = ('python -m venv .venv && . .venv/bin/activate && pip install torch==2.13.0 && '
               'pip install -e ".[train]" && gpcnav reproduce --quick --out out/quick')
"""The README's first set-up command, byte for byte as it has always been."""


def _blocks(lang: str) -> list[tuple[int, str]]:
    """``(offset in the README, text)`` of every fenced block of ``lang``, in order."""
    return [(m.start(), m.group(2)) for m in FENCE.finditer(TEXT) if m.group(1) == lang]


def _is_setup(block: str) -> bool:
    return "python -m venv" in block


PYTHON = _blocks("python")
BASH = [b for b in _blocks("bash") if not _is_setup(b[1])]
SETUP = [b for _, b in _blocks("bash") if _is_setup(b)]


def _save_as(offset: int) -> str | None:
    """The file name the README tells the reader to save the block at ``offset`` as."""
    before = TEXT[:offset].rstrip().rsplit("\n\n", 1)[-1]
    m = re.search(r"Save this as `([^`]+)`", before)
    return m.group(1) if m else None


def _expected_prints(block: str) -> list[str] | None:
    lines = block.rstrip("\n").splitlines()
    for i, line in enumerate(lines):
        m = re.match(r"#\s*prints:\s*(.*)$", line)
        if m:
            rest = [re.sub(r"^#\s?", "", x) for x in lines[i + 1:]]
            return ([m.group(1)] if m.group(1) else []) + rest
    return None


def _commands(block: str) -> list[tuple[str, str]]:
    """``(command, trailing comment)`` for every command line of a bash block."""
    out, pending = [], ""
    for raw in block.splitlines():
        line = pending + raw
        if line.endswith("\\"):
            pending = line[:-1] + " "
            continue
        pending = ""
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        m = re.match(r"^(.*?)\s+#\s*(.*)$", line)
        out.append((m.group(1), m.group(2)) if m else (line.strip(), ""))
    return out


def _shortened(cmd: str) -> str:
    cmd = re.sub(r"--count \d+", "--count 2", cmd)
    cmd = re.sub(r"--samples \d+", "--samples 200", cmd)
    if cmd.startswith("gpcnav train") and "--epochs" not in cmd:
        cmd += " --epochs 5"
    return cmd


def _option(cmd: str, name: str) -> str | None:
    m = re.search(rf"(?:^|\s){re.escape(name)}[ =](\S+)", cmd)
    return m.group(1) if m else None


@pytest.fixture(scope="module")
def checkout(tmp_path_factory) -> Path:
    """A fresh copy of the checkout: what git tracks, and what it would track (not ignored)."""
    dest = tmp_path_factory.mktemp("checkout")
    listed = subprocess.run(["git", "ls-files", "-z", "-co", "--exclude-standard"], cwd=REPO,
                            capture_output=True, text=True) if shutil.which("git") else None
    if listed is not None and listed.returncode == 0 and listed.stdout:
        for rel in filter(None, listed.stdout.split("\0")):
            src = REPO / rel
            if src.is_file():
                (dest / rel).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(src, dest / rel)
    else:  # no git: the tree without what a checkout does not hold
        shutil.copytree(REPO, dest, dirs_exist_ok=True, ignore=shutil.ignore_patterns(
            ".git", ".venv", "out", "build", "__pycache__", "*.egg-info", ".pytest_cache", ".hypothesis"))
    return dest


def _env(root: Path) -> dict:
    """The user's environment with the copy's packages first and the interpreter's scripts
    (``gpcnav``, ``python``) on the path, as in the README's activated virtual environment."""
    bindir = str(Path(sys.executable).parent)
    return {**os.environ, "PYTHONPATH": str(root), "PATH": bindir + os.pathsep + os.environ.get("PATH", ""),
            "MPLBACKEND": "Agg"}


def _shell(cmd: str, root: Path, timeout: int = 300) -> subprocess.CompletedProcess:
    prelude = "" if shutil.which("gpcnav", path=str(Path(sys.executable).parent)) else \
        f'gpcnav() {{ "{sys.executable}" -m gpcnav "$@"; }}\n'
    return subprocess.run(["bash", "-c", prelude + cmd], cwd=root, env=_env(root), capture_output=True,
                          text=True, timeout=timeout)


def _check_outputs(cmd: str, comment: str, proc: subprocess.CompletedProcess, root: Path) -> None:
    """What a command says it does, read back from what it printed and wrote."""
    sub = cmd.split()[1]
    wanted = next((o for o in OUTCOMES if comment.startswith(o)), None)
    if wanted:
        got = re.findall(r"\]: (reached_goal|collided|timed_out)\b", proc.stdout)
        assert got == [wanted], (cmd, proc.stdout)
    out = _option(cmd, "--out")
    if out:
        path = root / out
        assert path.exists(), (cmd, out)
        if sub == "simulate":
            check_run_document(json.loads(path.read_text()))
        elif sub == "evaluate":
            doc = json.loads(path.read_text())
            assert doc["episodes"] == int(_option(cmd, "--count")) == len(doc["episodes_detail"])
            assert doc["success_rate"] + doc["collision_rate"] + doc["timeout_rate"] == pytest.approx(1.0)
        elif sub == "compare":
            doc = json.loads(path.read_text())
            asked = _option(cmd, "--controllers").split(",")
            assert [c["controller"] for c in doc["controllers"]] == asked
            assert all(c["episodes"] == int(_option(cmd, "--count")) for c in doc["controllers"])
            details = [[e["scenario"] for e in c["episodes_detail"]] for c in doc["controllers"]]
            assert all(d == details[0] for d in details), "the same episodes for every controller"
        elif sub == "dataset":
            manifest = json.loads((path / "manifest.json").read_text())
            assert manifest["samples"] == int(_option(cmd, "--samples"))
        elif sub == "train":
            assert path.is_dir() and any(path.iterdir())
        elif sub == "export":
            import onnxruntime
            session = onnxruntime.InferenceSession(str(path))
            meta = session.get_modelmeta().custom_metadata_map
            assert int(meta["n_features"]) == session.get_inputs()[0].shape[1] > 0
        elif sub == "bench":
            doc = json.loads(path.read_text())
            assert doc["chosen"]["name"] in [r["name"] for r in doc["results"]]
        elif sub == "import-tracks":
            from scenarios import load_scenario
            files = sorted(path.glob("*.toml"))
            assert len(files) == int(_option(cmd, "--max-cases"))
            assert all(load_scenario(f).moving for f in files)
    plot = _option(cmd, "--plot")
    if plot:
        assert (root / plot).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", (cmd, plot)


def _write_saved_files(root: Path, before: int) -> None:
    for offset, code in PYTHON:
        name = _save_as(offset)
        if name and offset < before:
            (root / name).write_text(code, encoding="utf-8")


def _run_block(offset: int, block: str, root: Path, slow: bool) -> int:
    _write_saved_files(root, offset)
    ran = 0
    for cmd, comment in _commands(block):
        if cmd.startswith(SLOW_COMMANDS) != slow:
            continue
        short = _shortened(cmd)
        proc = _shell(short, root, timeout=600 if slow else 300)
        assert proc.returncode == 0, (short, proc.stdout[-2000:], proc.stderr[-2000:])
        _check_outputs(short, comment, proc, root)
        ran += 1
    return ran


def test_the_readme_has_code_to_run():
    assert len(PYTHON) >= 3 and len(BASH) >= 2 and len(SETUP) == 2
    assert sum(len(_commands(b)) for _, b in BASH) >= 8
    assert any(_save_as(o) == "mymod.py" for o, _ in PYTHON)


def test_the_set_up_commands_are_the_ones_ci_runs():
    """The two set-up commands, one line each: the second is the line ``.ci/run`` runs
    verbatim, the first is unchanged, and both install the extras the project declares."""
    first, second = (s.strip("\n").splitlines() for s in SETUP)
    assert len(first) == 1 and len(second) == 1
    assert first[0] == SETUP_FIRST
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert second[0] in ci
    pyproject = (REPO / "pyproject.toml").read_text(encoding="utf-8")
    assert re.search(r"^train = \[", pyproject, re.M) and re.search(r"^test = \[", pyproject, re.M)


@pytest.mark.parametrize("offset,code", PYTHON, ids=[f"python-{i + 1}" for i in range(len(PYTHON))])
def test_each_python_block_runs_alone(checkout, offset, code):
    proc = subprocess.run([sys.executable, "-c", code], cwd=checkout, env=_env(checkout), capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    expected = _expected_prints(code)
    if expected is not None:
        assert proc.stdout.splitlines() == expected


@pytest.mark.parametrize("offset,block", BASH, ids=[f"bash-{i + 1}" for i in range(len(BASH))])
def test_each_bash_block_runs_as_written(checkout, offset, block):
    """Every line but the slow ones, shortened where a run is long."""
    ran = _run_block(offset, block, checkout, slow=False)
    assert ran == sum(not c.startswith(SLOW_COMMANDS) for c, _ in _commands(block))


@pytest.mark.slow
def test_the_long_commands_run_as_written(checkout):
    """``gpcnav bench`` and ``gpcnav reproduce`` from the bash blocks, and the first set-up
    command's ``gpcnav reproduce --quick`` as written (its report is where the README says)."""
    ran = sum(_run_block(offset, block, checkout, slow=True) for offset, block in BASH)
    assert ran >= 1
    tail = SETUP_FIRST.split(" && ")[-1]
    proc = _shell(tail, checkout, timeout=3600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = (checkout / _option(tail, "--out") / "report.md").read_text(encoding="utf-8")
    assert "Fig. 7" in report and "| paper | fig7_1_head_on | gpc |" in report


def _prose() -> str:
    """The README without its fenced blocks and code spans."""
    return re.sub(r"`[^`\n]*`", "", FENCE.sub("", TEXT))


def test_the_readme_is_short_and_speaks_to_a_new_user():
    assert len(TEXT.splitlines()) < 200
    internal = re.findall(r"\b(?:[dmr]\d{1,2}|plan\d|[pi](?:35|64|128)x?\w*)\b", TEXT)
    assert not internal, internal
    prose = _prose().lower()
    for other_name in ("shield", "safety filter", "safety layer", "contract"):
        assert other_name not in prose, other_name
    assert "the check layer" in prose


def test_every_project_path_the_readme_names_exists():
    project = r'(?<![\w/.":])((?:docs|scenarios|tools|nn_export|casadi_gpc|gpcnav|tests|\.ci)/[\w./-]*\w)'
    named = set(re.findall(project, TEXT))  # a quoted "gpcnav/..." (or "gpcnav:gpcnav/...") is an id, not a path
    named |= set(re.findall(r"\]\(([^)\s]+)\)", TEXT))
    assert len(named) >= 10
    missing = sorted(p for p in named if not (REPO / p).exists())
    assert not missing, missing
