"""tools/trace_episode.py: the decisions it lists are the episode's own, and what it says of
the followed mover is checked against the simulated truth."""
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).parents[1]
_spec = importlib.util.spec_from_file_location("trace_episode", ROOT / "tools" / "trace_episode.py")
trace_episode = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(trace_episode)


def _scenario(name):
    from scenarios import load_scenario
    return load_scenario(ROOT / "scenarios" / "paper" / f"{name}.toml")


def test_the_blind_robot_collision_is_traced_to_the_mover_it_hit():
    sc = _scenario("fig7_1_head_on")
    log, seen = trace_episode.run(sc, "blind")
    assert log.outcome == "collided" and log.collision["obstacle"] == "moving"
    j, tc = log.collision["index"], log.collision["time_s"]
    rows = trace_episode.rows(log, seen, [j], tc - 2.0, tc)
    T = log.sample_time_s
    assert rows and tc - T <= rows[-1]["t_s"] <= tc and rows[0]["t_s"] >= tc - 2.0 - 1e-9
    for r in rows:
        k = int(round(r["t_s"] / T))
        x, y = log.states[k][:2]
        assert r["robot"][:2] == (x, y)
        m = r["movers"][0]
        p = log.obstacle_xy[k][j]
        assert m["index"] == j and m["distance_m"] == pytest.approx(math.hypot(p[0] - x, p[1] - y))
        # the sensor's noise is 0.02 m: each measurement lies within 5 of it of the truth
        assert len(m["measured_m"]) == 1 and math.dist(m["measured_m"][0], p) < 0.1
        assert m["forecasts"] == []  # the blind robot forecasts nothing
    out = trace_episode.text(log, rows)
    assert out.splitlines()[0].startswith("fig7_1_head_on: collided") and f"mover {j} at" in out


def test_the_planner_forecasts_are_listed_and_close_to_where_the_mover_went():
    """The paper's crossing obstacle moves at constant velocity: the GPC's one-step forecast
    of it, as listed, is within 0.1 m of where it really was a sample later."""
    sc = _scenario("fig7_2_crossing")
    log, seen = trace_episode.run(sc, "gpc")
    T = log.sample_time_s
    rows = trace_episode.rows(log, seen, [0], 5.0, 15.0)
    assert len(rows) == 21
    for r in rows:
        k = int(round(r["t_s"] / T))
        (f,) = r["movers"][0]["forecasts"]
        assert math.dist(f["means_m"][0], log.obstacle_xy[k + 1][0]) < 0.1
        assert np.all(np.asarray(f["first_std_m"]) > 0)


def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys):
    assert trace_episode.main([str(tmp_path / "missing.toml")]) == 2
    assert trace_episode.main([]) == 2
    assert trace_episode.main([str(ROOT / "scenarios" / "paper" / "fig7_1_head_on.toml"), "--mover", "7"]) == 2
    # a name of no controller was the UsageError's traceback
    assert trace_episode.main([str(ROOT / "scenarios" / "paper" / "fig7_1_head_on.toml"), "--controller", "gcp"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 4 and all(line.startswith("trace_episode: ") for line in err)
    assert "--controller 'gcp': not a controller" in err[-1]
    with pytest.raises(SystemExit) as exit_:  # (a preset of no name was the ValueError's traceback)
        trace_episode.main([str(ROOT / "scenarios" / "paper" / "fig7_1_head_on.toml"), "--preset", "bogus"])
    assert exit_.value.code == 2 and "--preset: invalid choice: 'bogus'" in capsys.readouterr().err
