"""``tools/retreat.py``: progress along the reference, the share of samples moving back, the
largest retreat and the distance driven back, against hand-worked episodes."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

TOOLS = Path(__file__).resolve().parents[1] / "tools"


def _tool():
    spec = importlib.util.spec_from_file_location("retreat", TOOLS / "retreat.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _run(xs, ys, path, outcome="timed_out", name="case"):
    return {"scenario": name, "outcome": outcome, "sample_time_s": 0.5, "path_length_m": 1.0,
            "reference_path": path, "trajectory": {"x": list(xs), "y": list(ys)}}


def test_progress_on_a_bent_path_and_beyond_its_ends():
    """An L (x from 0 to 4, then y from 0 to 3): points beside each leg, before its start and
    past its end, their arc lengths worked by hand."""
    rt = _tool()
    path = np.array([[0.0, 0.0], [2.0, 0.0], [4.0, 0.0], [4.0, 1.5], [4.0, 3.0]])
    xy = np.array([[1.0, 0.3], [-2.0, 0.1], [3.9, 2.0], [4.2, 5.0], [3.0, -0.2]])
    np.testing.assert_allclose(rt.progress_m(path, xy), [1.0, -2.0, 6.0, 9.0, 3.0], atol=1e-12)


def test_an_episode_that_backs_off_behind_its_start():
    """Forward 1 m in two samples, back 2.5 m (behind the start) in five, a slow creep back
    (0.02 m a sample, 0.04 m/s: not moving back), then forward: the steps moving back (5 of
    12), the largest retreat (2.54 m, the creep included) and the distance driven back (2.5 m)."""
    rt = _tool()
    xs = [0.0, 0.5, 1.0, 0.5, 0.0, -0.5, -1.0, -1.5, -1.52, -1.54, 0.0, 1.0, 2.0]
    out = rt.episode(_run(xs, [0.1] * len(xs), [[0.0, 0.0], [5.0, 0.0]]))
    assert out["share_moving_back"] == pytest.approx(5 / 12)
    assert out["largest_retreat_m"] == pytest.approx(2.54)
    assert out["driven_back_m"] == pytest.approx(2.5)


def test_the_command_summarises_by_outcome_and_refuses_a_bad_file(tmp_path, capsys):
    rt = _tool()
    a = tmp_path / "a.json"
    b = tmp_path / "b.json"
    a.write_text(json.dumps(_run([0, 1, 2, 3], [0, 0, 0, 0], [[0, 0], [3, 0]], "reached_goal", "a")))
    b.write_text(json.dumps(_run([0, 1, 0, -1], [0, 0, 0, 0], [[0, 0], [3, 0]], "timed_out", "b")))
    out = tmp_path / "RETREAT.json"
    assert rt.main([str(a), str(b), "--out", str(out)]) == 0
    summ = json.loads(out.read_text())["summary"]
    assert summ["reached_goal"]["largest_retreat_m_median"] == 0.0
    assert summ["timed_out"]["largest_retreat_m_max"] == pytest.approx(2.0)
    bad = tmp_path / "bad.json"
    bad.write_text("{}")
    assert rt.main([str(bad)]) == 2
    assert "bad.json" in capsys.readouterr().err


@pytest.mark.parametrize("argv, says", [(["--suite", "nope"], "unknown suite"),
                                        (["--suite", "corridor", "--controller", "nope"], "not a controller"),
                                        (["--suite", "corridor", "--count", "0"], "count must be at least 1"),
                                        ([], "one of the two")])
def test_bad_arguments_are_refused_in_one_line(argv, says, capsys):
    assert _tool().main(argv) == 2
    err = capsys.readouterr().err
    assert says in err and err.count("\n") == 1
