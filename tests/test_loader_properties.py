"""The scenario loader under mutated files (hypothesis): valid files with keys deleted,
added and misspelt, values of the wrong type or shape, huge, tiny and non-finite numbers,
broken TOML text, and the newer fields (``track``, ``walls``, ``[sensing] range_m``) with
random contents. Every one ends in a valid :class:`~scenarios.Scenario` or a one-line
:class:`~scenarios.ScenarioError` naming the file, never another exception.

Fast (no simulation): part of the default suite. ``HYPOTHESIS_PROFILE=thorough`` runs ten
times more examples."""
from __future__ import annotations

import copy
import math
import os
import tempfile
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import PAPER_DIR
from scenarios import Scenario, ScenarioError, load_scenario, scenario_from_dict

SCALE = 10 if os.environ.get("HYPOTHESIS_PROFILE") == "thorough" else 1
SOURCE = "mutated.toml"

WALKERS = """
name = "walkers"
description = "two walkers, a static obstacle, an arc, sensing and faults"
duration_s = 30.0
[robot]
position = [0.0, 0.0]
heading_deg = 0.0
radius_m = 0.3
max_wheel_speed_mps = 0.8
[reference]
position = [0.0, 0.0]
heading_deg = 0.0
speed_mps = 0.4
[[reference.segments]]
line_m = 4.0
[[reference.segments]]
arc_radius_m = 3.0
arc_angle_deg = -45.0
[[moving_obstacles]]
position = [3.0, 2.0]
radius_m = 0.3
behaviour = "orca"
goal = [3.0, -2.0]
preferred_speed_mps = 0.4
sees_robot = true
[[moving_obstacles]]
position = [6.0, 0.0]
heading_deg = 180.0
speed_mps = 0.4
turn_rate_deg_s = 2.0
radius_m = 0.3
[[static_obstacles]]
position = [5.0, 1.5]
radius_m = 0.3
[sensing]
position_noise_std_m = 0.02
seed = 3
[faults]
dropout_prob = 0.1
delay_steps = 1
"""

BASES = [tomllib.loads((PAPER_DIR / "fig7_1_head_on.toml").read_text()), tomllib.loads(WALKERS)]

SPECIAL_NUMBERS = [math.nan, math.inf, -math.inf, 0, 0.0, -0.0, -1, -1e-9, 1e-300, 5e-324, 1e308, -1e308, 2 ** 63,
                   -(2 ** 63), 10 ** 400, -(10 ** 400), True, False]
NEW_FIELDS = ("track", "walls", "range_m", "points", "behaviour")

scalars = st.one_of(
    st.booleans(), st.integers(), st.integers(min_value=-(10 ** 500), max_value=10 ** 500),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from(SPECIAL_NUMBERS),
    st.text(max_size=8), st.sampled_from(["orca", "social_force", "constant", "replay", "", "ORCA"]), st.none())
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                       st.dictionaries(st.text(max_size=6), inner, max_size=3)),
                      max_leaves=8)
track_rows = st.lists(st.lists(st.one_of(st.floats(-1e3, 1e3), st.sampled_from(SPECIAL_NUMBERS)), min_size=0,
                               max_size=4), max_size=5)


def _containers(doc, path=()):
    """Every (path, container) in the document: the tables and the lists."""
    out = [(path, doc)]
    items = doc.items() if isinstance(doc, dict) else enumerate(doc) if isinstance(doc, list) else ()
    for key, v in items:
        if isinstance(v, (dict, list)):
            out += _containers(v, path + (key,))
    return out


@st.composite
def mutated(draw):
    doc = copy.deepcopy(draw(st.sampled_from(BASES)))
    for _ in range(draw(st.integers(1, 4))):
        places = _containers(doc)
        _, box = draw(st.sampled_from(places))
        action = draw(st.sampled_from(["delete", "add", "replace", "special", "wrap", "unwrap", "grow", "shrink",
                                       "new_field"]))
        keys = list(box.keys()) if isinstance(box, dict) else list(range(len(box)))
        if action == "add" or action == "new_field" or not keys:
            name = draw(st.sampled_from(NEW_FIELDS)) if action == "new_field" else draw(st.text(min_size=1, max_size=8))
            value = draw(track_rows if name in ("track", "points") else values)
            if isinstance(box, dict):
                box[name] = value
            else:
                box.append(value if draw(st.booleans()) else {name: value})
            continue
        key = draw(st.sampled_from(keys))
        if action == "delete":
            del box[key]
        elif action == "replace":
            box[key] = draw(values)
        elif action == "special":
            box[key] = draw(st.sampled_from(SPECIAL_NUMBERS))
        elif action == "wrap":
            box[key] = [box[key]]
        elif action == "unwrap" and isinstance(box[key], list) and box[key]:
            box[key] = box[key][0]
        elif action == "grow" and isinstance(box[key], list):
            box[key] = box[key] + draw(st.lists(values, min_size=1, max_size=3))
        elif action == "shrink" and isinstance(box[key], list):
            box[key] = box[key][: draw(st.integers(0, max(0, len(box[key]) - 1)))]
        else:
            box[key] = draw(values)
    return doc


def _finite_numbers(obj) -> bool:
    """Every number inside a loaded scenario is finite."""
    from dataclasses import fields, is_dataclass
    if isinstance(obj, bool) or obj is None or isinstance(obj, str):
        return True
    if isinstance(obj, (int, float)):
        return math.isfinite(obj)
    if is_dataclass(obj):
        return all(_finite_numbers(getattr(obj, f.name)) for f in fields(obj))
    if isinstance(obj, (list, tuple)):
        return all(_finite_numbers(v) for v in obj)
    if isinstance(obj, dict):
        return all(_finite_numbers(v) for v in obj.values())
    return True


def _loads_or_one_line_error(load, source: str = SOURCE) -> Scenario | None:
    try:
        scenario = load()
    except ScenarioError as exc:
        text = str(exc)
        assert len(text.splitlines()) == 1 and text.startswith(f"{source}: "), text
        return None
    assert isinstance(scenario, Scenario)
    assert _finite_numbers(scenario), scenario
    assert math.isfinite(scenario.reference.length_m) and scenario.reference.length_m > 0
    return scenario


def test_the_unmutated_bases_load():
    for doc in BASES:
        assert isinstance(scenario_from_dict(copy.deepcopy(doc), SOURCE), Scenario)


@settings(max_examples=400 * SCALE, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much])
@given(mutated())
def test_a_mutated_document_loads_or_is_refused_in_one_line(doc):
    _loads_or_one_line_error(lambda: scenario_from_dict(doc, SOURCE))


TEXT = (PAPER_DIR / "fig7_2_crossing.toml").read_text()


@settings(max_examples=150 * SCALE, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, len(TEXT)), st.integers(0, 12),
       st.one_of(st.text(max_size=12), st.sampled_from(["nan", "inf", "-inf", "1e999", "9" * 40, "[", "]]", "=",
                                                        "\"", "\n[robot]\n", "\nwalls = 3\n", "\x00", "\udcff"])))
def test_a_mutated_file_loads_or_is_refused_in_one_line(at, cut, insert):
    text = TEXT[:at] + insert + TEXT[at + cut:]
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / SOURCE
        path.write_bytes(text.encode("utf-8", errors="surrogateescape"))
        _loads_or_one_line_error(lambda: load_scenario(path), str(path))


@pytest.mark.parametrize("key", ["x\ny", "a\rb", "line\u2028break", "tab\there", "\x85"])
def test_a_key_with_a_line_break_is_refused_in_one_line(key):
    for doc in BASES:
        doc = copy.deepcopy(doc)
        doc["robot"][key] = 1.0
        with pytest.raises(ScenarioError) as err:
            scenario_from_dict(doc, SOURCE)
        assert len(str(err.value).splitlines()) == 1 and "unknown key" in str(err.value)


@pytest.mark.parametrize("field, value", [
    ("duration_s", 10 ** 400), ("duration_s", 1e308), ("robot.position", [10 ** 400, 0]),
    ("robot.heading_deg", 10 ** 400), ("reference.speed_mps", 10 ** 400), ("reference.segments.0.line_m", 1e308),
    ("sensing.seed", 10 ** 400), ("robot.radius_m", 1e308),
])
def test_huge_numbers_are_refused_in_one_line(field, value):
    """Numbers too large to be a float, or a place, length or time no scenario has, are
    refused by name (they used to end in OverflowError or an infinite path length)."""
    doc = copy.deepcopy(BASES[1])
    box, *path = field.split(".")
    target = doc
    keys = [box, *path]
    for key in keys[:-1]:
        target = target[int(key)] if isinstance(target, list) else target[key]
    target[keys[-1]] = value
    with pytest.raises(ScenarioError) as err:
        scenario_from_dict(doc, SOURCE)
    assert "\n" not in str(err.value) and keys[-1] in str(err.value)
