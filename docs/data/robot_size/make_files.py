"""Scenario files of a suite's episodes with the robot's radius changed (nothing else): the
same people, walls, references and sensor noise, so a table can set robots of several sizes
side by side. ``python make_files.py SUITE COUNT SEED MOVERS BEHAVIOUR RADIUS OUT_DIR``
(MOVERS and BEHAVIOUR as ``gpcnav evaluate``'s ``--movers`` and ``--behaviour``; ``-`` for the
suite's default)."""
import sys
from dataclasses import replace
from pathlib import Path

from scenarios.suites import Suite
from scenarios.writer import scenario_document, to_toml

suite, count, seed, movers, behaviour, radius, out = sys.argv[1:8]
kw = {} if movers == "-" else {"movers": int(movers)}
if behaviour != "-":
    kw["behaviour"] = behaviour
s = Suite(suite, int(count), int(seed), **kw)
out = Path(out)
out.mkdir(parents=True, exist_ok=True)
for i in range(s.count):
    sc = s.scenario(i)
    sc = replace(sc, robot=replace(sc.robot, radius_m=float(radius)))
    (out / f"{sc.name}.toml").write_text(to_toml(scenario_document(sc)), encoding="utf-8")
print(f"{s.count} files in {out}")
