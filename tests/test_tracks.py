"""Recorded tracks as movers (scenarios.model.TrackSpec, scenarios.movers), the sensing range,
the collision's details, the ETH/UCY reader and the case protocol (``gpcnav import-tracks``)."""
from __future__ import annotations

import gzip
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from casadi_gpc.types import ControlDecision
from conftest import assert_refused_in_one_line, straight_line_toml
from gpcnav.cli import main
from scenarios import ScenarioError, load_scenario, scenario_from_dict
from scenarios.metrics import episode_metrics, eval_document, run_document
from scenarios.simulator import Episode, simulate

BASE = straight_line_toml("tracks", 12.0, 4.0)
REPO_RECORDINGS = Path(__file__).resolve().parents[1] / "scenarios" / "recordings"


def _scenario(movers: str, extra: str = ""):
    return scenario_from_dict(tomllib.loads(BASE + extra + movers), "t.toml")


class _Still:
    sample_time_s = 0.5

    def reset(self):
        pass

    def decide(self, obs):
        self.seen = getattr(self, "seen", []) + [tuple(m.obstacle_id for m in obs.moving)]
        return ControlDecision(0.0, 0.0)


class _Forward(_Still):
    def decide(self, obs):
        r = obs.robot
        dv = 0.2
        return ControlDecision(min(r.v_right_mps + dv, 0.4), min(r.v_left_mps + dv, 0.4))


# --- bad track files: one line, exit 2 --------------------------------------------------------

BAD = {
    "one row": ("track = [[0.0, 5.0, 0.0]]", "needs at least two rows"),
    "times not increasing": ("track = [[0.0, 5.0, 0.0], [2.0, 4.0, 0.0], [2.0, 3.0, 0.0]]", "increase strictly"),
    "negative time": ("track = [[-1.0, 5.0, 0.0], [2.0, 4.0, 0.0]]", "must not be negative"),
    "with position": ("track = [[0.0, 5.0, 0.0], [2.0, 4.0, 0.0]]\nposition = [5.0, 0.0]", "not for a mover with a track"),
    "with goal": ("track = [[0.0, 5.0, 0.0], [2.0, 4.0, 0.0]]\ngoal = [5.0, 0.0]", "not for a mover with a track"),
    "non-finite": ("track = [[0.0, 5.0, nan], [2.0, 4.0, 0.0]]", "must be finite"),
    "infinite time": ("track = [[0.0, 5.0, 0.0], [inf, 4.0, 0.0]]", "must be finite"),
    "short row": ("track = [[0.0, 5.0], [2.0, 4.0, 0.0]]", "three numbers"),
    "text in a row": ("track = [[0.0, 5.0, 'a'], [2.0, 4.0, 0.0]]", "three numbers"),
    "not a list": ("track = 3", "list of [t_s, x_m, y_m] rows"),
    "misspelt track": ("trak = [[0.0, 5.0, 0.0], [2.0, 4.0, 0.0]]", "a recorded one: track"),  # was told a
    # constant mover's keys alone, as if tracks were not a thing
    "unknown behaviour": ('track = [[0.0, 5.0, 0.0], [2.0, 4.0, 0.0]]\nbehaviour = "constant"', "replay, orca, social_force"),
    "replay that sees": ("track = [[0.0, 5.0, 0.0], [2.0, 4.0, 0.0]]\nsees_robot = true", "cannot give way"),
    "starts on the robot": ("track = [[0.0, 0.3, 0.0], [2.0, 4.0, 0.0]]", "starts overlapping"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_track_refused_in_one_line_with_exit_2(case, tmp_path, capsys):
    body, words = BAD[case]
    f = tmp_path / "bad.toml"
    f.write_text(BASE + "[[moving_obstacles]]\nradius_m = 0.25\n" + body + "\n")
    assert_refused_in_one_line(f, words, capsys)


def test_bad_sensing_range_refused():
    with pytest.raises(ScenarioError, match="range_m: must be positive"):
        _scenario("", "[sensing]\nrange_m = 0.0\n")


# --- the movers ----------------------------------------------------------------------------------

def test_a_replayed_track_is_the_recording_and_exists_only_between_its_rows():
    sc = _scenario("[[moving_obstacles]]\nradius_m = 0.25\ntrack = [[1.0, 6.0, 2.0], [3.0, 6.0, 4.0], [5.0, 4.0, 4.0]]\n")
    ep = Episode(sc, 0.5)
    w = ep.world
    assert np.allclose(w.positions(2.0)[0], (6.0, 3.0))       # halfway along the first row interval
    assert np.allclose(w.positions(4.0)[0], (5.0, 4.0))
    assert np.allclose(w.velocities(4.0)[0], (-1.0, 0.0))
    assert np.all(np.isnan(w.positions(0.5)[0])) and np.all(np.isnan(w.positions(5.5)[0]))
    pol = _Still()
    simulate(sc, pol)
    present = [k for k, ids in enumerate(pol.seen) if ids]
    assert present[0] == 2 and present[-1] == 10          # t = 1.0 s to 5.0 s, samples of 0.5 s


def test_a_long_recordings_absent_people_cost_nothing_and_read_as_before():
    """A world of many replayed tracks, a few in the scene at a time (a whole recording's
    people, 0.04 s rows): the positions are each track's ``recorded_at`` where it exists and
    NaN elsewhere, as mover by mover, and only the tracks that exist at one of the times asked
    are interpolated (every track was, 60 ms a sample with the 415 people of students001)."""
    from scenarios.model import TrackSpec
    from scenarios.movers import MoverWorld
    rng = np.random.default_rng(3)
    movers = []
    for k in range(300):
        start = round(float(rng.uniform(0.0, 150.0)), 2)
        t = start + 0.04 * np.arange(int(rng.integers(2, 400)))
        xy = rng.normal(0.0, 5.0, 2) + np.cumsum(rng.normal(0.0, 0.05, (len(t), 2)), axis=0)
        movers.append(TrackSpec(0.25, tuple(map(tuple, np.column_stack([t, xy]).tolist()))))
    world = MoverWorld(movers)
    ts = np.concatenate([np.linspace(0.0, 170.0, 401), [movers[0].start_s, movers[0].end_s]])
    got = world.positions(ts)
    for j, m in enumerate(movers):
        want = np.where(m.exists_at(ts)[:, None], m.recorded_at(ts), np.nan)
        assert np.array_equal(got[:, j], want, equal_nan=True), j
        assert np.array_equal(world.exists(ts[5]), [bool(mm.exists_at(ts[5])) for mm in movers])
    asked = []
    original = TrackSpec.recorded_at
    try:
        TrackSpec.recorded_at = lambda self, t: asked.append(self) or original(self, t)
        t = 75.0 + 0.025 * np.arange(1, 21)                # one sample interval's collision instants
        world.positions(t)
    finally:
        TrackSpec.recorded_at = original
    present = [m for m in movers if m.exists_at(t).any()]
    assert 0 < len(asked) == len(present) < 60


def test_walker_steps_count_the_walkers_in_the_scene():
    """``movers.walker_steps`` counted every track walker at every grid step, in the scene
    or not (a recording's 415 people: seven times the steps taken)."""
    from scenarios.model import TrackSpec, WalkerSpec
    from scenarios.movers import MoverWorld
    world = MoverWorld([TrackSpec(0.25, ((0.0, 5.0, 0.0), (10.0, 6.0, 0.0)), "orca"),
                        TrackSpec(0.25, ((2.0, 5.0, 3.0), (3.0, 6.0, 3.0)), "orca"),
                        TrackSpec(0.25, ((20.0, 5.0, 3.0), (30.0, 6.0, 3.0)), "orca"),
                        WalkerSpec((0.0, -3.0), 0.25, "orca", (0.0, -8.0), 0.5)])
    world.advance(5.0)
    # 50 grid steps: the first walker decides in each, the second in the 10 from its entry at
    # 2.0 s to its last, at 2.9 s (it leaves at 3.0 s), the third never, the goal walker in all
    assert world.steps == 50 and world.counters["walker_steps"] == 50 + 10 + 0 + 50


def test_the_sensor_lists_only_movers_within_range():
    movers = ("[[moving_obstacles]]\nradius_m = 0.25\ntrack = [[0.0, 3.0, 2.0], [12.0, 3.0, 2.0]]\n"
              "[[moving_obstacles]]\nradius_m = 0.25\ntrack = [[0.0, 9.0, 0.0], [12.0, 9.0, 0.0]]\n")
    pol = _Still()
    simulate(_scenario(movers, "[sensing]\nrange_m = 5.0\n"), pol)
    assert set(pol.seen[0]) == {0}
    pol = _Still()
    simulate(_scenario(movers), pol)
    assert set(pol.seen[0]) == {0, 1}


def test_unseen_measurements_count_movers_in_the_scene_the_sensor_missed_not_those_absent():
    """``unseen_measurements`` (docs/scenarios.md: the movers the sensor left unmeasured, out of
    range or behind a wall) counted a track mover before its first row and after its last too:
    a recording's cases reported tens of thousands (students001: 72 387 in 12 episodes), with no
    range and no wall hiding anyone."""
    later = "[[moving_obstacles]]\nradius_m = 0.25\ntrack = [[2.0, 3.0, 2.0], [4.0, 3.0, 2.0]]\n"
    far = "[[moving_obstacles]]\nradius_m = 0.25\ntrack = [[0.0, 9.0, 0.0], [2.0, 9.0, 0.0]]\n"
    log = simulate(_scenario(later + far), _Still())          # 24 decisions, at 0, 0.5, ... 11.5 s
    assert log.events.get("unseen_measurements", 0) == 0
    log = simulate(_scenario(later + far, "[sensing]\nrange_m = 5.0\n"), _Still())
    assert log.events["unseen_measurements"] == 5              # the far one, in the scene at 0 ... 2 s


def test_a_walker_that_follows_its_recording_keeps_to_it_alone_and_gives_way_to_the_robot():
    walk = "[[0.0, 6.0, 0.0], [10.0, 2.0, 0.0]]"          # straight at the robot standing at the origin
    alone = _scenario('[[moving_obstacles]]\nradius_m = 0.25\nbehaviour = "orca"\ntrack = [[0.0, 6.0, 3.0], [10.0, 2.0, 3.0]]\n')
    ep = Episode(alone, 0.5)
    ep.world.advance(8.0)
    err = max(np.hypot(*(ep.world.positions(t)[0] - alone.moving[0].recorded_at(t))) for t in np.arange(0.5, 8.0, 0.5))
    assert err < 0.2
    sees = _scenario(f'[[moving_obstacles]]\nradius_m = 0.25\nbehaviour = "orca"\nsees_robot = true\ntrack = {walk}\n'
                     .replace("[10.0, 2.0, 0.0]", "[10.0, -4.0, 0.0]"))
    log = simulate(sees, _Still())
    assert log.outcome != "collided" and log.min_clearance_m > 0.0
    replay = _scenario(f"[[moving_obstacles]]\nradius_m = 0.25\ntrack = {walk.replace('[10.0, 2.0, 0.0]', '[10.0, -4.0, 0.0]')}\n")
    assert simulate(replay, _Still()).outcome == "collided"


# --- the collision's details ---------------------------------------------------------------------

def test_walked_into_is_not_the_robots_doing_and_driving_into_someone_is():
    walker = "[[moving_obstacles]]\nradius_m = 0.25\ntrack = [[0.0, 4.0, 0.0], [8.0, 0.0, 0.0]]\n"
    log = simulate(_scenario(walker), _Still())
    c = log.collision
    assert log.outcome == "collided" and c["obstacle"] == "moving" and c["index"] == 0
    assert abs(c["robot_speed_towards_mps"]) < 1e-9 and c["obstacle_age_s"] == pytest.approx(c["time_s"])
    # the time of first contact: 4 m - 0.6 m of discs at 0.5 m/s
    assert c["time_s"] == pytest.approx(6.8, abs=0.5 / 20 + 1e-9)
    standing = "[[moving_obstacles]]\nradius_m = 0.25\ntrack = [[0.0, 2.0, 0.0], [12.0, 2.0, 0.0]]\n"
    hit = simulate(_scenario(standing), _Forward())
    assert hit.collision["robot_speed_towards_mps"] == pytest.approx(0.4, abs=1e-6)
    m1, m2 = episode_metrics(log), episode_metrics(hit)
    assert not m1.robot_approaching and m2.robot_approaching
    doc = eval_document("x", [m1, m2], [0.0])
    assert doc["collided_robot_approaching"] == 1 and doc["collision_rate"] == 1.0
    run = run_document(hit)
    assert run["collision"]["obstacle"] == "moving" and run["obstacles"][0]["track_start_s"] == 0.0


def test_someone_appearing_on_the_robot_is_a_ghost_not_the_robots_doing():
    ghost = "[[moving_obstacles]]\nradius_m = 0.25\ntrack = [[3.0, 1.0, 0.0], [8.0, 1.0, 0.0]]\n"
    log = simulate(_scenario(ghost), _Forward())
    assert log.outcome == "collided" and log.collision["obstacle_age_s"] < 1.0
    assert not episode_metrics(log).robot_approaching
    doc = run_document(log)
    assert doc["obstacles"][0]["x"][0] is None                 # not in the scene at t = 0: null, not NaN


def test_a_contact_exactly_the_ghost_time_after_the_first_row_is_the_robots_doing():
    """Known answer: the robot drives at 0.4 m/s from t = 0 (x = 0.4 t) into a person standing at
    x = 1.205 from t = 0.4 s; the discs (0.35 + 0.3 m) first overlap at a check instant at
    t = 1.4 s (1.205 - 0.56 < 0.65; at 1.375 s, 1.205 - 0.55 = 0.655): the person had existed
    1 s, the contract's "at least 1 s" (1.4 - 0.4 was 0.9999999999999999 and not counted)."""
    class Drive(_Still):
        def decide(self, obs):
            return ControlDecision(0.4, 0.4)
    person = "[[moving_obstacles]]\nradius_m = 0.3\ntrack = [[0.4, 1.205, 0.0], [10.0, 1.205, 0.0]]\n"
    log = simulate(_scenario(person), Drive())
    c = log.collision
    assert log.outcome == "collided" and c["time_s"] == pytest.approx(1.4, abs=1e-12)
    assert c["obstacle_age_s"] == pytest.approx(1.0, abs=1e-12) and c["robot_speed_towards_mps"] == pytest.approx(0.4)
    assert episode_metrics(log).robot_approaching
    assert eval_document("x", [episode_metrics(log)], [0.0])["collided_robot_approaching"] == 1


# --- the recordings and the case protocol --------------------------------------------------------

def test_frame_time_follows_the_recording():
    from scenarios.recordings import seconds_per_frame
    assert seconds_per_frame("biwi_eth.txt") == pytest.approx(1 / 15)
    assert seconds_per_frame("crowds_zara01.txt") == pytest.approx(1 / 25)
    assert seconds_per_frame("biwi_hotel.txt") == pytest.approx(1 / 25)
    # the parts of the recordings as Trajectron++'s and Social-GAN's folders split them
    for part in ("biwi_eth_train.txt", "biwi_eth_val.txt", "BIWI_ETH_test.txt", "/data/eth/biwi_eth.txt.gz"):
        assert seconds_per_frame(part) == pytest.approx(1 / 15), part
    for part in ("biwi_hotel_train.txt", "crowds_zara03_val.txt", "students001_train.txt", "uni_examples.txt",
                 "biwi_ethics.txt"):
        assert seconds_per_frame(part) == pytest.approx(1 / 25), part


def _excerpt(tmp_path, seconds: float = 60.0):
    """The first ``seconds`` of crowds_zara01, as a plain four-column file."""
    from scenarios.recordings import RECORDINGS_DIR
    rows = [r for r in gzip.decompress((RECORDINGS_DIR / "crowds_zara01.txt.gz").read_bytes()).decode().splitlines()
            if r.split() and float(r.split()[0]) / 25 <= seconds]
    f = tmp_path / "crowds_zara01.txt"
    f.write_text("\n".join(rows) + "\n")
    return f


def test_import_tracks_writes_the_protocols_cases_as_scenario_files(tmp_path, capsys):
    from scenarios.pedestrian_cases import DURATION_S, PATH_LENGTH_M, case_scenario, cases
    from scenarios.recordings import read_recording
    f = _excerpt(tmp_path, 150.0)
    rec = read_recording(f)
    assert rec.seconds_per_frame == pytest.approx(0.04)
    expected = cases(rec)
    assert expected
    out = tmp_path / "cases"
    assert main(["import-tracks", str(f), "--out", str(out)]) == 0
    files = sorted(out.glob("*.toml"))
    assert len(files) == len(expected)
    for k, case in enumerate(expected):
        sc = load_scenario(out / f"{case.name}.toml")
        assert sc.moving == case_scenario(rec, case, seed=k).moving
        assert sc.duration_s == DURATION_S and sc.reference.length_m == pytest.approx(PATH_LENGTH_M)
        assert sc.sensing.range_m == 8.0
        t0 = case.start_s
        for m in sc.moving:                              # every person as the recording has them
            src = min(rec.tracks, key=lambda tr: np.hypot(*(np.interp(t0 + m.start_s, tr[:, 0], tr[:, 1:].T[0]) - m.xy_m[0, 0],
                                                                np.interp(t0 + m.start_s, tr[:, 0], tr[:, 1:].T[1]) - m.xy_m[0, 1])))
            tt = t0 + m.times_s
            assert np.allclose(np.interp(tt, src[:, 0], src[:, 1]), m.xy_m[:, 0], atol=2e-4)
    assert "cases written" in capsys.readouterr().out


def test_a_case_keeps_everyone_whose_track_overlaps_it(tmp_path):
    """A case's start is the recording's start plus whole seconds: on ``crowds_zara02``
    (rows at 0.4 s from 0.4 s) it lands 4e-15 s before a row, the row was kept beside the
    cut's interpolated one, the two rounded to the same time and the person was dropped from
    the case: 7 of the 13 people of its third case, people in the scene at the start among
    them (769 people in 70 of the recording's 243 cases)."""
    from scenarios.pedestrian_cases import DURATION_S, case_scenario, cases
    from scenarios.recordings import RECORDINGS_DIR, read_recording
    rows = [r for r in gzip.decompress((RECORDINGS_DIR / "crowds_zara02.txt.gz").read_bytes()).decode().splitlines()
            if r.split() and float(r.split()[0]) / 25 <= 45.0]
    f = tmp_path / "crowds_zara02.txt"
    f.write_text("\n".join(rows) + "\n")
    rec = read_recording(f)
    found = cases(rec)
    assert len(found) >= 3
    for case in found:
        t0, t1 = case.start_s, case.start_s + DURATION_S
        overlapping = [tr for tr in rec.tracks if tr[-1, 0] > t0 and tr[0, 0] < t1]
        sc = case_scenario(rec, case)
        assert len(sc.moving) == len(overlapping), case.name
        for m in sc.moving:
            assert np.all(np.diff(m.times_s) > 0)
        at_start = [tr for tr in overlapping if tr[0, 0] <= t0 + 1e-9]
        assert sum(m.start_s == 0.0 for m in sc.moving) == len(at_start), case.name


def test_import_tracks_refuses_bad_recordings_in_one_line(tmp_path, capsys):
    cases = {"three columns": "0 1 2.0\n", "text": "0 1 a 2\n", "non-finite": "0 1 nan 2\n",
             "twice at a frame": "0 1 1 1\n0 1 2 2\n", "empty": "\n",
             "too large": "0 1 1e300 1.0\n10 1 -1e300 2.0\n",  # numpy overflow warnings came before the line
             "one row a person": "0 1 1 1\n0 2 2 2\n10 3 3 3\n", "five columns": "0 1 1 1 1\n10 1 2 2 2\n"}
    for name, text in cases.items():
        f = tmp_path / f"{name.replace(' ', '_')}.txt"
        f.write_text(text)
        assert main(["import-tracks", str(f), "--out", str(tmp_path / "o")]) == 2, name
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and str(f) in err, name
    assert not (tmp_path / "o").exists()
    assert main(["import-tracks", str(_excerpt(tmp_path)), "--out", str(tmp_path / "o"),
                 "--seconds-per-frame", "-1"]) == 2
    capsys.readouterr()
    # frames 1e-300 s long: the speeds overflowed and numpy's warnings made the refusal five lines
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")                          # (pytest keeps warnings off stderr)
        assert main(["import-tracks", str(_excerpt(tmp_path)), "--out", str(tmp_path / "o"),
                     "--seconds-per-frame", "1e-300"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no case" in err, err
    assert not (tmp_path / "o").exists()


def test_import_tracks_names_cases_that_every_command_reads(tmp_path, capsys):
    """A recording's file name with a space, a '+', a non-ASCII letter, a second dot or a
    leading dot made case names the loader refuses (written all the same), cut at the first dot
    or read as an option (found by an audit): the cases are named from the name made valid."""
    from scenarios.recordings import recording_name
    assert recording_name("crowds_zara01.txt.gz") == "crowds_zara01"  # the shipped cases keep their names
    assert recording_name("/data/my rec.txt") == "my_rec" and recording_name("eth+ucy.TXT") == "eth_ucy"
    assert recording_name("café.txt") == "caf_" and recording_name("zara.v2.txt") == "zara_v2"
    assert recording_name(".hidden.txt") == "hidden" and recording_name("-dash.txt") == "dash"
    assert recording_name("++.txt") == "recording"
    text = _excerpt(tmp_path, 40.0).read_text()
    for fname, prefix in (("my rec.txt", "my_rec-"), ("zara.v2.txt", "zara_v2-")):
        (tmp_path / fname).write_text(text)
        out = tmp_path / prefix
        assert main(["import-tracks", str(tmp_path / fname), "--out", str(out), "--max-cases", "3"]) == 0
        files = sorted(out.glob("*.toml"))
        assert len(files) == 3
        for f in files:
            assert f.name.startswith(prefix) and load_scenario(f).name == f.stem
    # into a folder that holds other cases: said, in one line (a glob of it takes them too)
    assert main(["import-tracks", str(tmp_path / "my rec.txt"), "--out", str(tmp_path / "zara_v2-"),
                 "--max-cases", "2"]) == 0
    assert "also holds 3 other scenario files" in capsys.readouterr().err


def test_a_case_is_the_same_file_whatever_max_cases_picks(tmp_path):
    """A case's noise seed is its place among all the recording's cases: it was its place among
    the cases written, so the same case made with --max-cases 2 and 4 drew other noise."""
    from scenarios.pedestrian_cases import cases
    from scenarios.recordings import shipped_recording
    rec = REPO_RECORDINGS / "crowds_zara01.txt.gz"
    found = cases(shipped_recording("crowds_zara01"))
    assert len(found) == 31  # --max-cases 2 writes cases 0 and 15; 4: 0, 7, 15 and 23
    for n in (2, 4):
        assert main(["import-tracks", str(rec), "--out", str(tmp_path / str(n)), "--max-cases", str(n)]) == 0
    name = f"{found[15].name}.toml"
    assert {f.name for f in (tmp_path / "2").glob("*.toml")} < {f.name for f in (tmp_path / "4").glob("*.toml")}
    two, four = (tmp_path / "2" / name).read_text(), (tmp_path / "4" / name).read_text()
    assert two == four and load_scenario(tmp_path / "4" / name).sensing.seed == 15


def test_a_start_on_which_someone_appears_within_a_second_is_skipped(tmp_path, capsys):
    """The start check looked at the people in the scene at the case's start only: someone
    appearing on the robot's start 0.4 s later (a person entering the recording there, whom
    nothing avoids) left the case in. Now it is skipped as a start with someone on it is, and
    import-tracks counts both kinds."""
    from scenarios.pedestrian_cases import cases
    from scenarios.recordings import read_recording
    text = gzip.decompress((REPO_RECORDINGS / "crowds_zara01.txt.gz").read_bytes()).decode()
    (tmp_path / "crowds_zara01.txt").write_text(text)
    before = cases(read_recording(tmp_path / "crowds_zara01.txt"))
    case = before[10]
    frame = round((case.start_s + 0.4) / 0.04)  # standing on the robot's start from 0.4 to 0.8 s after it
    x, y = case.start_xy
    (tmp_path / "crowds_zara01.txt").write_text(text + f"{frame} 9999 {x + 0.3} {y}\n{frame + 10} 9999 {x + 0.3} {y}\n")
    after = cases(read_recording(tmp_path / "crowds_zara01.txt"))
    assert case.start_s not in [c.start_s for c in after if c.task == case.task]
    assert len(after) == len(before) - 1
    skipped = {}
    cases(read_recording(tmp_path / "crowds_zara01.txt"), skipped)
    assert skipped == {"occupied": 5, "appears": 1}
    assert main(["import-tracks", str(tmp_path / "crowds_zara01.txt"), "--out", str(tmp_path / "o"),
                 "--max-cases", "1"]) == 0
    assert "(6 starts skipped, someone within 0.5 m of the robot's disc: 5 there at the start, 1 appearing " \
           "within 1 s)" in capsys.readouterr().out


def test_import_tracks_takes_a_stray_row_far_away(tmp_path):
    """The busiest square is found over the occupied cells: a person 100 km away asked a dense
    grid for 75 GB (a traceback, exit 1; found by an audit). Now the same cases as without them."""
    from scenarios.pedestrian_cases import cases
    from scenarios.recordings import read_recording
    f = _excerpt(tmp_path, 60.0)
    far = tmp_path / "far.txt"
    far.write_text(f.read_text() + "0 9999 100000.0 100000.0\n10 9999 100000.0 100000.0\n")  # standing: the flow as before
    base, with_far = cases(read_recording(f)), cases(read_recording(far))
    assert base and [(c.task, c.start_s, c.start_xy) for c in base] == [(c.task, c.start_s, c.start_xy) for c in with_far]
    assert main(["import-tracks", str(far), "--out", str(tmp_path / "o"), "--max-cases", "1"]) == 0


def test_the_ucy_suite_is_seeded_and_covers_every_case():
    from scenarios import Suite
    a, b = Suite("ucy", 3, 1).scenarios(), Suite("ucy", 3, 1).scenarios()
    assert [s.name for s in a] == [s.name for s in b] and a[0].moving == b[0].moving
    assert Suite("ucy", 3, 2).scenario(0).name != a[0].name or Suite("ucy", 3, 2).scenario(1).name != a[1].name
    reactive = Suite("ucy", 1, 1, behaviour="orca").scenario(0)
    assert reactive.moving[0].behaviour == "orca" and reactive.moving[0].sees_robot
    with pytest.raises(ValueError, match="behaviour"):
        Suite("ucy", 1, 1, behaviour="constant")
    assert math.isclose(a[0].reference.speed_mps, 0.4)


def test_forecast_accuracy_is_exact_on_a_straight_walk_and_the_straight_forecast_beats_the_turning_one_on_a_wiggle():
    """``tools/forecast_accuracy.py``: a person walking a straight line at constant speed is
    forecast exactly by every predictor (ADE under a millimetre); one who wiggles (a turn one
    way, then back) is forecast closer by the filter's straight forecast than by its turning
    one, which carries the last turn on."""
    import importlib.util
    from pathlib import Path
    from scenarios.recordings import Recording
    path = Path(__file__).resolve().parents[1] / "tools" / "forecast_accuracy.py"
    spec = importlib.util.spec_from_file_location("forecast_accuracy", path)
    fa = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fa)
    t = np.arange(60) * 0.4
    straight = Recording("line", 0.04, (np.c_[t, 1.0 + 1.2 * t, 2.0 - 0.3 * t],))
    for predictor in (fa.predict_ekf, fa.predict_ekf_straight, fa.predict_cv):
        ade, fde, n = fa.errors(straight, predictor)
        assert n == 60 - 19 and ade < 1e-3 and fde < 2e-3
    heading = 0.6 * np.sin(2 * np.pi * t / 12.0)  # a slow weave, period 12 s
    xy = np.cumsum(np.c_[np.cos(heading), np.sin(heading)] * 1.2 * 0.4, axis=0)
    wiggle = Recording("wiggle", 0.04, (np.c_[t, xy],))
    turning, straightened = fa.errors(wiggle, fa.predict_ekf)[0], fa.errors(wiggle, fa.predict_ekf_straight)[0]
    assert straightened < turning


def test_a_walker_who_sees_the_robot_never_enters_on_it_and_the_move_is_counted():
    """A recording may start someone on the robot's spot; a walker who gives way to the robot
    enters beside it instead (counted), a blind walker and a replayed track where recorded."""
    from scenarios.movers import ENTRY_CLEARANCE_M
    on_robot = "track = [[1.0, 0.2, 0.1], [6.0, 3.0, 2.0]]\n"     # appears at t = 1 s, inside the robot's disc
    sees = _scenario(f'[[moving_obstacles]]\nradius_m = 0.25\nbehaviour = "orca"\nsees_robot = true\n{on_robot}')
    log = simulate(sees, _Still())
    assert log.outcome != "collided" and log.min_clearance_m > 0.0
    assert log.events["movers.entered_beside_robot"] == 1
    ep = Episode(sees, 0.5)
    ep.world.advance(1.0, lambda t: (0.0, 0.0, 0.0, 0.0))
    entry = ep.world.positions(1.0)[0]
    robot_r = sees.robot.radius_m
    # on the line from the robot's centre through the recorded point, the clearance away
    assert np.hypot(*entry) == pytest.approx(robot_r + 0.25 + ENTRY_CLEARANCE_M)
    assert entry[1] / entry[0] == pytest.approx(0.1 / 0.2)
    assert np.isnan(ep.world.positions(0.95)[0]).all()          # not in the scene before its first row
    blind = _scenario(f'[[moving_obstacles]]\nradius_m = 0.25\nbehaviour = "orca"\n{on_robot}')
    blind_log = simulate(blind, _Still())
    assert blind_log.outcome == "collided" and "movers.entered_beside_robot" not in blind_log.events
    assert blind_log.collision["obstacle_age_s"] == pytest.approx(0.0, abs=1e-9)
    replay = _scenario(f"[[moving_obstacles]]\nradius_m = 0.25\n{on_robot}")
    assert simulate(replay, _Still()).outcome == "collided"
    # one that starts clear of the robot enters where its recording is, uncounted
    clear = _scenario('[[moving_obstacles]]\nradius_m = 0.25\nbehaviour = "orca"\nsees_robot = true\n'
                      'track = [[1.0, 3.0, 2.0], [6.0, 6.0, 2.0]]\n')
    ep = Episode(clear, 0.5)
    ep.world.advance(1.0, lambda t: (0.0, 0.0, 0.0, 0.0))
    assert ep.world.positions(1.0)[0] == pytest.approx([3.0, 2.0])
    assert ep.world.counters["entered_beside_robot"] == 0


def test_a_walker_whose_recording_starts_on_the_robots_centre_enters_on_the_side_it_comes_from():
    from scenarios.movers import ENTRY_CLEARANCE_M
    # first row exactly on the robot's centre at t = 1 s, walking +y: it enters below the robot
    sc = _scenario('[[moving_obstacles]]\nradius_m = 0.25\nbehaviour = "orca"\nsees_robot = true\n'
                   'track = [[1.0, 0.0, 0.0], [3.0, 0.0, 2.0]]\n')
    ep = Episode(sc, 0.5)
    ep.world.advance(1.0, lambda t: (0.0, 0.0, 0.0, 0.0))
    assert ep.world.positions(1.0)[0] == pytest.approx([0.0, -(sc.robot.radius_m + 0.25 + ENTRY_CLEARANCE_M)])
    assert ep.world.counters["entered_beside_robot"] == 1


def test_a_tracks_top_speed_is_taken_over_spans_of_a_frame_or_more():
    """The speed a track walker's cap is made from: between consecutive rows wherever they are
    10 ms or more apart (the same number as before, to the bit: the shipped cases' rows are
    0.2 s or more apart); rows microseconds apart (a file may hold them) are taken together
    with the next, so a person walking at 1.2 m/s is not read as walking at thousands of m/s."""
    from scenarios.model import TrackSpec
    rows = [(0.0, 0.0, 0.0), (0.4, 0.48, 0.0), (0.8, 0.96, 0.1), (1.2, 1.3, 0.1)]
    t = TrackSpec(0.25, tuple(rows), "orca", False)
    old = np.hypot(*np.diff(t.xy_m, axis=0).T) / np.diff(t.times_s)
    assert t.max_recorded_speed_mps == float(old.max())
    odd = TrackSpec(0.25, ((0.0, 0.0, 0.0), (1e-6, 1e-3, 0.0), (0.4, 0.48, 0.0), (0.8, 0.96, 0.0)), "orca", False)
    assert math.isclose(odd.max_recorded_speed_mps, 1.2, rel_tol=1e-9)  # 0 -> 0.4 s, 1e-6 -> 0.4 s, 0.4 -> 0.8 s
    assert np.max(np.hypot(*np.diff(odd.xy_m, axis=0).T) / np.diff(odd.times_s)) > 900  # row to row: 1 000 m/s
    fine = TrackSpec(0.25, tuple((0.04 * k, 0.048 * k, 0.0) for k in range(31)), "orca", False)
    assert math.isclose(fine.max_recorded_speed_mps, 1.2, rel_tol=1e-9)


def test_import_tracks_shows_a_progress_bar_on_a_terminal(tmp_path):
    """CONTRACT.md: a progress bar for any work longer than a few seconds on a terminal. Writing the
    cases of students003 took 26 s (0.1-0.2 s a case, each written and read back) in silence."""
    import re

    from conftest import gpcnav_on_a_terminal
    res, lines = gpcnav_on_a_terminal("import-tracks", _excerpt(tmp_path, 150.0), "--out", tmp_path / "cases",
                                      "--max-cases", "3")
    assert res.returncode == 0 and "3 cases written" in res.stdout
    assert any(re.match(r"cases: +100%\|.*\| 3/3", ln) for ln in lines), lines[-4:]


def test_import_tracks_refuses_a_case_name_taken_by_a_folder_before_writing_any(tmp_path, capsys):
    """A folder (or a pipe) where a case is to be written ended the run with os.replace's
    IsADirectoryError traceback, exit 1, the cases before it written."""
    f = _excerpt(tmp_path, 40.0)
    out = tmp_path / "o"
    assert main(["import-tracks", str(f), "--out", str(out), "--max-cases", "2"]) == 0
    names = sorted(p.name for p in out.glob("*.toml"))
    capsys.readouterr()
    for p in out.glob("*.toml"):
        p.unlink()
    (out / names[-1]).mkdir()
    assert main(["import-tracks", str(f), "--out", str(out), "--max-cases", "2"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and f"{names[-1]} is a folder" in err, err
    assert sorted(p.name for p in out.iterdir()) == [names[-1]]
