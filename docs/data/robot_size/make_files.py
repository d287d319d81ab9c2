"""Scenario files of a suite's episodes with the robot's radius changed (nothing else): the
same people, walls, references and sensor noise, so a table can set robots of several sizes
side by side. ``python make_files.py SUITE COUNT SEED MOVERS BEHAVIOUR RADIUS OUT_DIR``
(MOVERS and BEHAVIOUR as ``gpcnav evaluate``'s ``--movers`` and ``--behaviour``; ``-`` for the
suite's default).

Every file is read back by the scenario loader before any is written: a radius the loader
refuses (not positive, a robot that would start touching a wall or a person) is one line
naming the episode, exit 2, and no file (they were all written, and gpcnav refused them)."""
import sys
import tomllib
from dataclasses import replace
from pathlib import Path

from scenarios.loader import ScenarioError, scenario_from_dict
from scenarios.suites import Suite
from scenarios.writer import scenario_document, to_toml

suite, count, seed, movers, behaviour, radius, out = sys.argv[1:8]
kw = {} if movers == "-" else {"movers": int(movers)}
if behaviour != "-":
    kw["behaviour"] = behaviour
s = Suite(suite, int(count), int(seed), **kw)
out = Path(out)
texts = {}
for i in range(s.count):
    sc = s.scenario(i)
    try:
        sc = replace(sc, robot=replace(sc.robot, radius_m=float(radius)))
        text = to_toml(scenario_document(sc))
        scenario_from_dict(tomllib.loads(text), f"{sc.name} (radius {radius})")
    except (ScenarioError, ValueError) as exc:  # (RobotParams refuses a radius that is no radius)
        print(f"make_files.py: error: {exc if isinstance(exc, ScenarioError) else f'{sc.name}: {exc}'}",
              file=sys.stderr)
        raise SystemExit(2)
    texts[out / f"{sc.name}.toml"] = text
out.mkdir(parents=True, exist_ok=True)
for path, text in texts.items():
    path.write_text(text, encoding="utf-8")
print(f"{s.count} files in {out}")
