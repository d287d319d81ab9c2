"""Buildings of other dimensions than the suites' (docs/buildings.md, "Corridors and doors of other widths"):
the three building suites' scenes (`scenarios.building_suite`: people walking both ways, blind to the robot)
with the corridor's width drawn from 1.8 to 3.2 m (the suites: 2.5 m; corridors of offices and hospitals are 1.8
to 3 m) and the door's from 0.9 to 1.6 m (the suites: 1.2 m; a single door's clear width to a double door's), the
kind in turn (corridor, doorway, corner), the people ORCA walkers in three of four scenes and social-force ones
in the fourth. Each scene is a scenario file (the contract's format), named with its width and door in cm.

    python docs/data/buildings/walls_widths/scenes.py OUT_DIR SEED COUNT
"""
import random
import sys
from pathlib import Path

import scenarios.building_suite as building
from scenarios.writer import scenario_document, to_toml

KINDS = ("corridor", "doorway", "corner")
WIDTH_M = (1.8, 3.2)
DOOR_M = (0.9, 1.6)


def main(out: Path, seed: int, count: int) -> None:
    rng = random.Random(seed)
    out.mkdir(parents=True, exist_ok=True)
    for i in range(count):
        kind = KINDS[i % 3]
        width, door = round(rng.uniform(*WIDTH_M), 2), round(rng.uniform(*DOOR_M), 2)
        behaviour = "social_force" if rng.random() < 0.25 else "orca"
        building.CORRIDOR_WIDTH_M, building.DOOR_WIDTH_M = width, door  # read when the scene is drawn
        sc = building.building_scenario(kind, i, seed, 5, behaviour)
        doc = scenario_document(sc)
        doc["name"] = f"{kind}-w{round(width * 100)}-d{round(door * 100)}-{behaviour}-{seed}-{i:04d}"
        (out / f"{doc['name']}.toml").write_text(to_toml(doc))
    print(f"{count} scenario files in {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]))
