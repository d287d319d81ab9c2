"""Scenario files of a suite's episodes for another robot: the robot of ROBOT.toml (its [robot]:
wheel base, radius, limits) in place of the contract's, the reference's speed and the time limit
scaled by SPEED_FACTOR (a slower robot is given a reference it can follow), the people, walls and
sensor noise as they are. ``python make_files.py SUITE COUNT SEED MOVERS ROBOT.toml SPEED_FACTOR
OUT_DIR`` (MOVERS as ``gpcnav evaluate``'s ``--movers``, ``-`` for the suite's default). Every file
is read back by the scenario loader before any is written (one line and exit 2 otherwise)."""
import sys
import tomllib
from pathlib import Path

from scenarios.loader import ScenarioError, scenario_from_dict
from scenarios.suites import Suite
from scenarios.writer import scenario_document, to_toml

suite, count, seed, movers, robot_file, factor, out = sys.argv[1:8]
factor = float(factor)
overrides = {k: v for k, v in tomllib.loads(Path(robot_file).read_text())["robot"].items()
             if k in ("wheel_base_m", "radius_m", "max_wheel_speed_mps", "max_wheel_accel_mps2")}
s = Suite(suite, int(count), int(seed), **({} if movers == "-" else {"movers": int(movers)}))
out = Path(out)
texts = {}
for i in range(s.count):
    doc = scenario_document(s.scenario(i))
    doc["robot"].update(overrides)
    doc["reference"]["speed_mps"] = doc["reference"]["speed_mps"] * factor
    doc["duration_s"] = doc["duration_s"] / factor
    text = to_toml(doc)
    try:
        scenario_from_dict(tomllib.loads(text), f"{doc['name']} ({robot_file})")
    except ScenarioError as exc:
        print(f"make_files.py: error: {exc}", file=sys.stderr)
        raise SystemExit(2)
    texts[out / f"{doc['name']}.toml"] = text
out.mkdir(parents=True, exist_ok=True)
for path, text in texts.items():
    path.write_text(text, encoding="utf-8")
print(f"{s.count} files in {out}")
