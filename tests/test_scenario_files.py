"""Scenario files: every bad file the contract lists is refused, by ``load_scenario`` with a
ScenarioError and by ``gpcnav simulate`` with exit status 2 and one stderr line that names
the file and the field; good files load to the values they say."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from conftest import PAPER_DIR, REPO
from scenarios import ScenarioError, load_scenario, paper_scenarios

GOOD = """\
name = "good_one"
description = "a valid scenario"
duration_s = 40.0

[robot]
position = [0.0, 0.0]
heading_deg = 0.0

[reference]
position = [0.0, 0.0]
heading_deg = 0.0
speed_mps = 0.4
[[reference.segments]]
line_m = 6.0
[[reference.segments]]
arc_radius_m = 3.0
arc_angle_deg = 90.0

[[moving_obstacles]]
position = [10.0, 0.0]
heading_deg = 180.0
speed_mps = 0.4
turn_rate_deg_s = 0.0
radius_m = 0.3

[[static_obstacles]]
position = [6.0, 1.5]
radius_m = 0.3

[sensing]
position_noise_std_m = 0.02
seed = 0
"""


def edit(old: str, new: str) -> str:
    assert GOOD.count(old) == 1, old
    return GOOD.replace(old, new)


# (id, file text, field that the message must name)
BAD = [
    ("not_toml", "name = \"x\"\nduration_s = = 3\n[robot\n", None),
    ("duplicate_key", "duration_s = 3.0\n" + GOOD, None),
    ("missing_name", edit('name = "good_one"\n', ""), "name"),
    ("missing_duration", edit("duration_s = 40.0\n", ""), "duration_s"),
    ("missing_robot", edit("[robot]\nposition = [0.0, 0.0]\nheading_deg = 0.0\n", ""), "robot"),
    ("missing_robot_heading", edit("position = [0.0, 0.0]\nheading_deg = 0.0\n\n[reference]",
                                   "position = [0.0, 0.0]\n\n[reference]"), "robot.heading_deg"),
    ("missing_reference_speed", edit("speed_mps = 0.4\n[[reference.segments]]", "[[reference.segments]]"),
     "reference.speed_mps"),
    ("missing_segments", edit("[[reference.segments]]\nline_m = 6.0\n[[reference.segments]]\narc_radius_m = 3.0\n"
                              "arc_angle_deg = 90.0\n", ""), "reference.segments"),
    ("missing_obstacle_radius", edit("turn_rate_deg_s = 0.0\nradius_m = 0.3\n", "turn_rate_deg_s = 0.0\n"),
     "moving_obstacles[0].radius_m"),
    ("missing_arc_angle", edit("arc_angle_deg = 90.0\n", ""), "reference.segments[1]"),
    ("wrong_type_duration", edit("duration_s = 40.0", 'duration_s = "40"'), "duration_s"),
    ("wrong_type_bool", edit("speed_mps = 0.4\n[[reference", "speed_mps = true\n[[reference"), "reference.speed_mps"),
    ("wrong_type_name", edit('name = "good_one"', "name = 3"), "name"),
    ("bad_name_chars", edit('name = "good_one"', 'name = "good one!"'), "name"),
    ("replay_without_track", edit("turn_rate_deg_s = 0.0\n", 'turn_rate_deg_s = 0.0\nbehaviour = "replay"\n'),
     "moving_obstacles[0].behaviour: 'replay' replays a recording: it needs a track"),
    ("name_trailing_line_break", edit('name = "good_one"', 'name = "good_one\\n"'), "name"),
    ("wrong_shape_position", edit("[robot]\nposition = [0.0, 0.0]", "[robot]\nposition = [0.0, 0.0, 1.0]"),
     "robot.position"),
    ("wrong_type_position", edit("[robot]\nposition = [0.0, 0.0]", '[robot]\nposition = [0.0, "a"]'),
     "robot.position"),
    ("robot_not_table", edit("[robot]\nposition = [0.0, 0.0]\nheading_deg = 0.0\n", "robot = 3\n"), "robot"),
    ("obstacles_not_array", edit("[[static_obstacles]]", "[static_obstacles]"), "static_obstacles"),
    ("seed_not_integer", edit("seed = 0", "seed = 1.5"), "sensing.seed"),
    ("nan_duration", edit("duration_s = 40.0", "duration_s = nan"), "duration_s"),
    ("inf_heading", edit("[robot]\nposition = [0.0, 0.0]\nheading_deg = 0.0",
                         "[robot]\nposition = [0.0, 0.0]\nheading_deg = inf"), "robot.heading_deg"),
    ("nan_in_position", edit("position = [6.0, 1.5]", "position = [nan, 1.5]"), "static_obstacles[0].position"),
    ("minus_inf_speed", edit("speed_mps = 0.4\nturn", "speed_mps = -inf\nturn"), "moving_obstacles[0].speed_mps"),
    ("nan_noise", edit("position_noise_std_m = 0.02", "position_noise_std_m = nan"), "sensing.position_noise_std_m"),
    ("negative_obstacle_radius", edit("turn_rate_deg_s = 0.0\nradius_m = 0.3", "turn_rate_deg_s = 0.0\nradius_m = -0.3"),
     "moving_obstacles[0].radius_m"),
    ("negative_static_radius", edit("position = [6.0, 1.5]\nradius_m = 0.3", "position = [6.0, 1.5]\nradius_m = -0.1"),
     "static_obstacles[0].radius_m"),
    ("zero_static_radius", edit("position = [6.0, 1.5]\nradius_m = 0.3", "position = [6.0, 1.5]\nradius_m = 0.0"),
     "static_obstacles[0].radius_m"),
    ("negative_robot_radius", edit("heading_deg = 0.0\n\n[reference]", "heading_deg = 0.0\nradius_m = -0.35\n\n"
                                   "[reference]"), "robot.radius_m"),
    # a wheel base of 1e-300 m was taken, and one solve of the planner never returned
    ("tiny_wheel_base", edit("heading_deg = 0.0\n\n[reference]", "heading_deg = 0.0\nwheel_base_m = 1e-300\n\n"
                             "[reference]"), "robot.wheel_base_m"),
    ("sub_centimetre_robot", edit("heading_deg = 0.0\n\n[reference]", "heading_deg = 0.0\nradius_m = 0.005\n\n"
                                  "[reference]"), "robot.radius_m"),
    ("negative_arc_radius", edit("arc_radius_m = 3.0", "arc_radius_m = -3.0"), "reference.segments[1].arc_radius_m"),
    ("zero_duration", edit("duration_s = 40.0", "duration_s = 0.0"), "duration_s"),
    ("zero_line", edit("line_m = 6.0", "line_m = 0.0"), "reference.segments[0].line_m"),
    ("zero_reference_speed", edit("speed_mps = 0.4\n[[reference", "speed_mps = 0.0\n[[reference"),
     "reference.speed_mps"),
    ("negative_obstacle_speed", edit("speed_mps = 0.4\nturn", "speed_mps = -0.1\nturn"), "moving_obstacles[0].speed_mps"),
    ("negative_noise", edit("position_noise_std_m = 0.02", "position_noise_std_m = -0.01"),
     "sensing.position_noise_std_m"),
    ("unknown_top_key", edit("duration_s = 40.0\n", "duration_s = 40.0\nduraton_s = 3.0\n"), "duraton_s"),
    ("unknown_robot_key", edit("[robot]\nposition = [0.0, 0.0]\nheading_deg = 0.0",
                               "[robot]\nposition = [0.0, 0.0]\nheading_deg = 0.0\nheadng_deg = 0.0"),
     "robot.headng_deg"),
    ("unknown_obstacle_key", edit("turn_rate_deg_s = 0.0\n", "turn_rate_deg_s = 0.0\nturn_rate = 1.0\n"),
     "moving_obstacles[0].turn_rate"),
    ("unknown_segment_key", edit("line_m = 6.0", "line_m = 6.0\nlength_m = 2.0"), "reference.segments[0].length_m"),
    ("unknown_sensing_key", edit("seed = 0", "sed = 0"), "sensing.sed"),
    ("unknown_table", GOOD + "\n[planner]\nhorizon = 6\n", "planner"),
    ("line_and_arc_in_one_segment", edit("line_m = 6.0", "line_m = 6.0\narc_radius_m = 2.0"),
     "reference.segments[0]"),
    ("zero_arc_angle", edit("arc_angle_deg = 90.0", "arc_angle_deg = 0.0"), "reference.segments[1].arc_angle_deg"),
    ("empty_path", edit("[[reference.segments]]\nline_m = 6.0\n[[reference.segments]]\narc_radius_m = 3.0\n"
                        "arc_angle_deg = 90.0\n", "segments = []\n"), "reference.segments"),
    ("reference_too_fast_line", edit("speed_mps = 0.4\n[[reference", "speed_mps = 0.85\n[[reference"),
     "reference.speed_mps"),
    # on an arc of radius R the outer wheel runs at v (1 + W / (2 R)): 0.5 m/s on R = 0.4 m
    # needs 0.5 * 1.625 = 0.81 m/s > 0.8
    ("reference_too_fast_tight_arc", edit("speed_mps = 0.4\n[[reference", "speed_mps = 0.5\n[[reference").replace(
        "arc_radius_m = 3.0", "arc_radius_m = 0.4"), "reference.speed_mps"),
    ("robot_inside_moving", edit("position = [10.0, 0.0]", "position = [0.5, 0.2]"), "moving_obstacles[0]"),
    ("robot_inside_static", edit("position = [6.0, 1.5]", "position = [-0.3, -0.3]"), "static_obstacles[0]"),
]


def test_the_good_file_loads_to_its_values(write_scenario):
    sc = load_scenario(write_scenario(GOOD))
    assert sc.name == "good_one" and sc.duration_s == 40.0
    assert sc.reference.length_m == pytest.approx(6.0 + 1.5 * math.pi)
    np.testing.assert_allclose(sc.reference.end_pose, [9.0, 3.0, math.pi / 2], atol=1e-12)
    assert sc.reference.speed_mps == 0.4
    (mov,) = sc.moving
    assert mov.position_m == (10.0, 0.0) and mov.heading_rad == pytest.approx(math.pi) and mov.radius_m == 0.3
    assert sc.static[0].position_m == (6.0, 1.5)
    assert sc.sensing.position_noise_std_m == 0.02 and sc.sensing.seed == 0
    assert sc.robot.radius_m == 0.35 and sc.robot.wheel_base_m == 0.5  # contract defaults


def test_a_file_saved_with_a_byte_order_mark_loads(tmp_path):
    """Windows editors (Notepad) save UTF-8 with a byte-order mark and CRLF line ends: the file
    was refused as 'not valid TOML (Invalid statement (at line 1, column 1))', naming nothing
    a person could see in it."""
    path = tmp_path / "notepad.toml"
    path.write_bytes(b"\xef\xbb\xbf" + GOOD.replace("\n", "\r\n").encode())
    assert load_scenario(path).name == "good_one"


def test_allowed_edge_values_load(write_scenario):
    """A speed of 0 for an obstacle, a noise of 0, robot overrides that make a fast reference
    reachable, integer numbers where floats are written, and a negative (right) arc."""
    text = (edit("speed_mps = 0.4\nturn", "speed_mps = 0\nturn")
            .replace("position_noise_std_m = 0.02", "position_noise_std_m = 0.0")
            .replace("heading_deg = 0.0\n\n[reference]", "heading_deg = 0\nmax_wheel_speed_mps = 1.0\n\n[reference]")
            .replace("speed_mps = 0.4\n[[reference", "speed_mps = 0.9\n[[reference")
            .replace("arc_angle_deg = 90.0", "arc_angle_deg = -90"))
    sc = load_scenario(write_scenario(text))
    assert sc.moving[0].speed_mps == 0.0 and sc.sensing.position_noise_std_m == 0.0
    assert sc.robot.max_wheel_speed_mps == 1.0 and sc.reference.speed_mps == 0.9
    np.testing.assert_allclose(sc.reference.end_pose, [9.0, -3.0, -math.pi / 2], atol=1e-12)
    # the reference just at the wheels' reach on the arc is accepted: 0.8 / (1 + 0.25 / 3)
    reach = 0.8 / (1 + 0.25 / 3.0)
    sc = load_scenario(write_scenario(edit("speed_mps = 0.4\n[[reference", f"speed_mps = {reach!r}\n[[reference")))
    assert sc.reference.speed_mps == reach
    # touching an obstacle is not overlapping it
    sc = load_scenario(write_scenario(edit("position = [6.0, 1.5]", "position = [0.65, 0.0]")))
    assert sc.static[0].position_m == (0.65, 0.0)


def test_paper_scenarios_load():
    scs = paper_scenarios()
    assert [s.name for s in scs] == ["fig7_1_head_on", "fig7_2_crossing", "fig7_3_crossing_off_path"]
    for s in scs:
        assert len(s.moving) == 1 and s.reference.length_m > 0
    assert sorted(p.stem for p in PAPER_DIR.glob("*.toml")) == [s.name for s in scs]


@pytest.mark.parametrize("case", BAD, ids=[c[0] for c in BAD])
def test_bad_file_raises_scenario_error(case, write_scenario):
    _, text, field = case
    path = write_scenario(text, "bad.toml")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith(str(path))
    if field is None:
        assert "TOML" in msg
    else:
        assert field in msg, msg


def test_missing_file_raises_scenario_error(tmp_path):
    with pytest.raises(ScenarioError, match="nothere.toml"):
        load_scenario(tmp_path / "nothere.toml")


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "gpcnav", *map(str, args)], capture_output=True, text=True,
                          cwd=REPO, timeout=120)


# a few through the command line, one of each kind; the rest above through the Python API
CLI_CASES = ["not_toml", "missing_robot_heading", "wrong_type_duration", "nan_duration", "negative_obstacle_radius",
             "unknown_robot_key", "empty_path", "reference_too_fast_tight_arc", "robot_inside_static"]


@pytest.mark.parametrize("name", CLI_CASES)
def test_simulate_refuses_bad_file(name, write_scenario):
    _, text, field = next(c for c in BAD if c[0] == name)
    path = write_scenario(text, f"{name}.toml")
    res = run_cli("simulate", path, "--controller", "gpc", "--preset", "paper")
    assert res.returncode == 2, res.stderr
    lines = res.stderr.splitlines()
    assert len(lines) == 1, res.stderr
    assert "Traceback" not in res.stderr
    assert str(path) in lines[0]
    assert (field or "TOML") in lines[0]
    assert res.stdout == ""


def test_simulate_refuses_a_missing_file(tmp_path):
    res = run_cli("simulate", tmp_path / "nothere.toml")
    assert res.returncode == 2
    assert len(res.stderr.splitlines()) == 1 and "nothere.toml" in res.stderr


def test_a_description_with_line_breaks_and_control_characters_is_written_back_as_it_reads():
    """scenarios.writer wrote a string as it was but for quotes and backslashes: a description with a
    line break (a file may say "a\\nb") made a file no TOML reader takes."""
    import tomllib
    from scenarios import scenario_from_dict
    from scenarios.writer import scenario_document, to_toml
    doc = tomllib.loads(GOOD)
    doc["description"] = 'two\nlines\r\n\ttab \x00 \x1f \x7f del "quoted" \\ back \u2028 \U0001F600'
    sc = scenario_from_dict(doc)
    again = scenario_from_dict(tomllib.loads(to_toml(scenario_document(sc))))
    assert again.description == doc["description"] and again.name == sc.name
