"""Shared fixtures: the repository's paths and a writer of scenario files."""
from __future__ import annotations

import os
from pathlib import Path

# Tiny matrices only: OpenBLAS worker threads do not help here, and on a loaded 2-core
# machine they made scipy's SLSQP (test_gpc_optimum) up to 10x slower. Set before numpy loads.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import pytest

REPO = Path(__file__).resolve().parents[1]
PAPER_DIR = REPO / "scenarios" / "paper"


def straight_line_toml(name: str, duration_s: float = 30.0, line_m: float = 4.0, extra: str = "") -> str:
    """A scenario file's text: the robot at the origin facing +x on a straight ``line_m``
    path at 0.4 m/s, and ``extra`` (obstacle tables) after it."""
    return (f'name = "{name}"\nduration_s = {duration_s}\n[robot]\nposition = [0.0, 0.0]\nheading_deg = 0.0\n'
            "[reference]\nposition = [0.0, 0.0]\nheading_deg = 0.0\nspeed_mps = 0.4\n"
            f"[[reference.segments]]\nline_m = {line_m}\n{extra}")


def gpcnav_on_a_terminal(*args: str):
    """``python -m gpcnav ARGS`` with its stderr on a pseudo-terminal (100 columns), stdout piped:
    ``(completed process, the terminal's lines)``, carriage returns read as line ends (each redraw
    of a progress bar a line)."""
    import fcntl
    import pty
    import struct
    import subprocess
    import sys
    import termios
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    res = subprocess.run([sys.executable, "-m", "gpcnav", *map(str, args)], stdout=subprocess.PIPE, stderr=slave,
                         text=True, cwd=REPO, timeout=300)
    os.close(slave)
    chunks = []
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:  # the terminal's other end is closed: everything is read
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(master)
    return res, b"".join(chunks).decode().replace("\r", "\n").splitlines()


def assert_refused_in_one_line(path: Path, words: str, capsys) -> None:
    """The scenario file ``path`` is refused by the loader with a ``ScenarioError`` that says
    ``words``, and by ``gpcnav simulate`` with exit 2 and one line saying them, no traceback."""
    import re

    from gpcnav.cli import main
    from scenarios import ScenarioError, load_scenario
    with pytest.raises(ScenarioError, match=re.escape(words)):
        load_scenario(path)
    assert main(["simulate", str(path), "--controller", "stand"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and words in err and "Traceback" not in err


@pytest.fixture
def write_scenario(tmp_path):
    """``write_scenario(text, name="scenario.toml") -> Path``: a scenario file in a temp dir."""
    def write(text: str, name: str = "scenario.toml") -> Path:
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
        return path
    return write


def check_run_document(doc: dict) -> None:
    """Assert that ``doc`` is a RUN.json as CONTRACT.md defines it (the same checks as
    ../shared/tools/check_outputs.py, which a fresh clone does not have)."""
    import json
    import math

    doc = json.loads(json.dumps(doc, allow_nan=False))  # plain JSON, all numbers finite
    num = (int, float)

    def is_num(v):
        return isinstance(v, num) and not isinstance(v, bool) and math.isfinite(v)

    assert isinstance(doc["scenario"], str) and isinstance(doc["controller"], str)
    assert doc["outcome"] in ("reached_goal", "collided", "timed_out")
    assert doc["collided"] is (doc["outcome"] == "collided")
    assert doc["reached_goal"] is (doc["outcome"] == "reached_goal")
    for key in ("min_clearance_m", "tracking_rmse_m", "sample_time_s"):
        assert is_num(doc[key]), key
    assert doc["tracking_rmse_m"] >= 0 and doc["sample_time_s"] > 0
    if doc["reached_goal"]:
        assert is_num(doc["time_to_goal_s"]) and doc["time_to_goal_s"] > 0
    else:
        assert doc["time_to_goal_s"] is None
    assert isinstance(doc["steps"], int) and not isinstance(doc["steps"], bool) and doc["steps"] >= 1
    ct = doc["compute_time_s"]
    assert all(is_num(ct[k]) for k in ("median", "p95", "max"))
    assert 0 <= ct["median"] <= ct["p95"] <= ct["max"]
    assert isinstance(doc["fallbacks"], int) and doc["fallbacks"] >= 0
    tr = doc["trajectory"]
    keys = ("t", "x", "y", "heading_rad", "v_right_mps", "v_left_mps")
    assert all(isinstance(tr[k], list) for k in keys)
    assert {len(tr[k]) for k in keys} == {doc["steps"] + 1}
    assert all(is_num(v) for k in keys for v in tr[k])
    assert isinstance(doc["obstacles"], list)
    for ob in doc["obstacles"]:
        assert ob["kind"] in ("moving", "static") and is_num(ob["radius_m"]) and ob["radius_m"] > 0
        assert len(ob["x"]) == len(ob["y"]) == doc["steps"] + 1
