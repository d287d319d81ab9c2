"""Scenario files of the three wall suites with a pillar, for rounds of the walls network's data
(docs/buildings.md, "Pillars in the walls network's data"):

    python make_files.py SUITE COUNT SEED OUT_DIR

Each file is the suite's episode ``i`` of ``SEED`` (5 ORCA walkers blind to the robot) with one
pillar placed by ``../pillars/pillars.py``'s rule (``with_pillar``: 0.25 m, on the reference 2.5
to 7.5 m along it, up to 0.5 m aside, 1 m from every wall), written as the loader reads it
(``scenarios.writer``); an episode with no place for a pillar is skipped and named.
"""
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[3]))
sys.path.insert(0, str(HERE.parent / "pillars"))

from pillars import with_pillar  # noqa: E402
from scenarios import Suite  # noqa: E402
from scenarios.writer import scenario_document, to_toml  # noqa: E402


def main(suite_name: str, count: int, seed: int, out: str) -> None:
    suite, out = Suite(suite_name, count, seed, 5, "orca"), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = 0
    for i in range(count):
        sc = with_pillar(suite.scenario(i), np.random.default_rng([seed, i]))
        if sc is None:
            print(f"{i}: no place for a pillar, skipped")
            continue
        (out / f"{sc.name}-pillar.toml").write_text(to_toml(scenario_document(sc)), encoding="utf-8")
        written += 1
    print(f"{out}: {written} files")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4])
