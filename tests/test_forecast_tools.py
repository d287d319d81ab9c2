"""The forecast studies on recorded people: ``tools/forecast_accuracy.py``'s coverage of the
forecast's uncertainty, and ``tools/forecast_bound.py``'s planner told the recording's future."""
from __future__ import annotations

import importlib.util
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np

from casadi_gpc.config import preset
from conftest import straight_line_toml
from gpcnav.controllers import make_controller
from scenarios import scenario_from_dict
from scenarios.recordings import Recording
from scenarios.simulator import Episode

TOOLS = Path(__file__).resolve().parents[1] / "tools"


def _tool(name: str):
    spec = importlib.util.spec_from_file_location(name, TOOLS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_coverage_is_full_on_a_straight_walk_and_grows_with_the_filters_noise_on_a_stop_and_go_walk():
    """A person walking a straight line at constant speed is within two standard deviations of
    the straight forecast at every checked step; one who stops and goes (1.4 m/s, then still,
    every 4 s) is not, and a filter told a larger speed noise claims less and so covers more."""
    fa = _tool("forecast_accuracy")
    t = np.arange(80) * 0.4
    line = Recording("line", 0.04, (np.c_[t, 1.0 + 1.2 * t, 2.0 - 0.3 * t],))
    assert fa.coverage(line) == [1.0, 1.0, 1.0]
    moving = (np.floor(t / 4.0) % 2 == 0).astype(float)
    x = np.concatenate([[0.0], np.cumsum(1.4 * 0.4 * moving[:-1])])
    stop_and_go = Recording("stop-and-go", 0.04, (np.c_[t, x, np.zeros_like(t)],))
    shipped = fa.coverage(stop_and_go)
    fa.SETTINGS = replace(fa.SETTINGS, speed_noise_mps2=0.5)
    noisy = fa.coverage(stop_and_go)
    assert max(shipped) < 0.9
    assert all(b > a for a, b in zip(shipped, noisy))


def test_the_planner_told_the_recording_plans_with_the_recorded_future():
    """``tools/forecast_bound.py``: with ``recording`` the forecasts the GPC decides (and is
    checked) with are the recorded positions at the H instants ahead, with no uncertainty;
    with ``next-sample`` the recorded position one sample ahead, then straight on at that
    sample's recorded velocity, with the filter's own uncertainty."""
    fb = _tool("forecast_bound")
    rows = [[0.0, 6.0, 1.0], [2.0, 4.0, 1.0], [4.0, 4.0, -1.0], [12.0, -4.0, -1.0]]
    text = straight_line_toml("bound", 12.0, 4.0) + f"[[moving_obstacles]]\nradius_m = 0.25\ntrack = {rows}\n"
    sc = scenario_from_dict(tomllib.loads(text), "bound.toml")
    config = preset("improved")
    H, T = config.horizon, config.sample_time_s
    track = sc.moving[0]
    for mode in ("recording", "next-sample"):
        ctl = make_controller("gpc", config, sc.robot)
        fb.told_the_recording(ctl.policy, sc, mode)
        ctl.reset()
        episode = Episode(sc, T)
        for _ in range(4):  # to t = 1.5 s, where the recording turns within the horizon
            obs = episode.observation()
            decision = ctl.decide(obs)
            episode.step(decision)
        (f,) = decision.forecasts
        ahead = track.recorded_at(obs.t_s + T * np.arange(1, H + 1))
        if mode == "recording":
            np.testing.assert_allclose(f.means_m, ahead, atol=1e-12)
            assert np.all(f.covs_m2 == 0.0)
        else:
            step = ahead[0] - track.recorded_at(obs.t_s)
            np.testing.assert_allclose(f.means_m, ahead[0] + step * np.arange(H)[:, None], atol=1e-12)
            assert not np.allclose(f.means_m, ahead)  # the turn at 2 s is not in it
            assert np.all(f.covs_m2[:, 0, 0] > 0.0)


def test_the_constant_velocity_row_repeats_the_last_measured_displacement():
    """``tools/forecast_bound.py``'s ``constant-velocity``: the forecast is the person's last
    measured position plus its displacement since the previous sample, repeated; at the first
    sample (one measurement) it is the planner's own."""
    fb = _tool("forecast_bound")
    text = straight_line_toml("cv", 12.0, 4.0) + (
        "[[moving_obstacles]]\nradius_m = 0.25\ntrack = [[0.0, 6.0, 2.0], [10.0, -4.0, 1.0]]\n")
    sc = scenario_from_dict(tomllib.loads(text), "cv.toml")
    config = preset("improved")
    H = config.horizon
    ctl = make_controller("gpc", config, sc.robot)
    fb.constant_velocity(ctl.policy)
    ctl.reset()
    own = make_controller("gpc", config, sc.robot)
    own.reset()
    episode = Episode(sc, config.sample_time_s)
    seen = []
    for k in range(3):
        obs = episode.observation()
        seen.append(np.asarray(obs.moving[0].position_m, dtype=float))
        decision = ctl.decide(obs)
        (f,) = decision.forecasts
        (g,) = own.decide(obs).forecasts
        if k == 0:
            np.testing.assert_allclose(f.means_m, g.means_m)
        else:
            np.testing.assert_allclose(f.means_m, seen[-1] + (seen[-1] - seen[-2]) * np.arange(1, H + 1)[:, None])
            if k == 2:  # with two measurements the filter's forecast is this one too; with three it smooths
                assert not np.allclose(f.means_m, g.means_m)
        np.testing.assert_allclose(f.covs_m2, g.covs_m2)
        episode.step(decision)


def test_the_bound_runs_on_scenario_files_and_refuses_what_is_not_replayed_people(tmp_path, capsys):
    """``tools/forecast_bound.py FILE ...``: another recording's cases (``gpcnav
    import-tracks``) in place of the ``ucy`` suite, with the record of each case as the suite
    path gives it; a file without replayed people, or that does not load, is refused in one
    line (exit 2)."""
    import pytest

    fb = _tool("forecast_bound")
    rows = [[0.0, 6.0, 0.0], [6.0, 0.0, 0.0]]  # a person walking at the robot down its reference
    text = straight_line_toml("walker", 10.0, 2.0) + f"[[moving_obstacles]]\nradius_m = 0.25\ntrack = {rows}\n"
    path = tmp_path / "walker.toml"
    path.write_text(text)
    sc = scenario_from_dict(tomllib.loads(text), str(path))
    doc = fb.run(1, 1, "improved", ("stand", "own"), scenarios=[sc], files=[str(path)])
    assert doc["files"] == [str(path)] and doc["count"] == 1 and doc["seed"] is None
    stand, own = doc["forecasts"]["stand"], doc["forecasts"]["own"]
    assert stand["collided"] == 1 and stand["episodes"][0]["outcome"] == "collided"  # walked into where it stands
    assert own["collided"] + own["reached"] + own["timed_out"] == 1
    assert fb.main([str(path), "--rows", "stand"]) == 0
    assert "| stands still | 0 | 1 |" in capsys.readouterr().out
    static = tmp_path / "static.toml"
    static.write_text(straight_line_toml("static", 4.0, 2.0))
    for bad, said in ((static, "not a case of people replayed open loop"), (tmp_path / "none.toml", "none.toml")):
        with pytest.raises(SystemExit) as exc:
            fb.main([str(bad)])
        assert exc.value.code == 2
        err = capsys.readouterr().err.strip().splitlines()[-1]
        assert said in err
