"""A pillar in our buildings: the three wall suites with one static disc added near the
robot's path, for the deployed network's walls network, which was trained on buildings with
people and no static obstacle (tools/build_models.sh), and which an option presents static
discs to as part of its wall scan (``OnnxPolicy(statics_as_walls=True)``).

    python pillars.py SUITE COUNT SEED VARIANT OUT.json

SUITE: corridor, doorway or corner (5 ORCA walkers blind to the robot, as the suites);
VARIANT: ``nn`` (the deployed network as shipped), ``nn-sw`` (the same with the option on),
``gpc``. Each episode ``i`` is the suite's episode ``i`` of ``SEED`` with one pillar of radius
0.25 m, drawn from its own generator (``SEED``, then ``i``): on the reference path 2.5 to 7.5 m
along it, moved sideways by up to 0.5 m, kept 1.0 m from every wall (so that the robot, 0.7 m
across, passes on one side at least), 0.9 m from every walker's start and 1.2 m from the
robot's; redrawn until it is (at most 1000 draws; an episode with no such place is skipped
and named). The pillar is known, like the walls: a static obstacle of the scenario format.
"""
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[4]))

from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.geometry import distance_to_segments_m, segment_rows  # noqa: E402
from casadi_gpc.types import StaticObstacle  # noqa: E402
from gpcnav.commands.common import for_run  # noqa: E402
from gpcnav.controllers import ControllerSpec, make  # noqa: E402
from scenarios import Suite  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402

RADIUS_M = 0.25


def with_pillar(sc, rng):
    walls = segment_rows([w.points for w in sc.walls])
    for _ in range(1000):
        s, side = rng.uniform(2.5, 7.5), rng.uniform(-0.5, 0.5)
        x, y, th = sc.reference.poses_along(s, 0.0, 1)[0]
        p = np.array([x - side * np.sin(th), y + side * np.cos(th)])
        far_walls = distance_to_segments_m(p, walls[:, :2], walls[:, 2:]).min() >= 1.0
        far_walkers = all(np.hypot(*(np.asarray(m.position_m) - p)) >= 0.9 for m in sc.moving)
        far_robot = np.hypot(p[0] - sc.robot_start.x_m, p[1] - sc.robot_start.y_m) >= 1.2
        if far_walls and far_walkers and far_robot:
            return replace(sc, static=tuple(sc.static) + (StaticObstacle((float(p[0]), float(p[1])), RADIUS_M),))
    return None


def main(suite_name: str, count: int, seed: int, variant: str, out: str) -> None:
    suite = Suite(suite_name, count, seed, 5, "orca")
    rows = []
    for i in range(count):
        sc = with_pillar(suite.scenario(i), np.random.default_rng([seed, i]))
        if sc is None:
            print(f"{i}: no place for a pillar, skipped", flush=True)
            continue
        cfg = for_run(preset("improved"), [sc])
        pol = make(ControllerSpec(variant.split("-")[0]), cfg, sc.robot)
        if variant == "nn-sw":
            pol.policy.statics_as_walls = True
        log = simulate(sc, pol, variant)
        col = log.collision or {}
        rows.append({"episode": i, "scenario": sc.name, "pillar": sc.static[-1].position_m, "outcome": log.outcome,
                     "min_clearance_m": float(log.min_clearance_m), "interventions": int(log.events.get("interventions", 0)),
                     "collision": {k: (float(v) if isinstance(v, (int, float, np.floating)) else v) for k, v in col.items()},
                     "decision_median_ms": float(np.median(log.compute_time_s) * 1e3)})
        print(i, log.outcome, round(float(log.min_clearance_m), 3), rows[-1]["interventions"], flush=True)
    Path(out).write_text(json.dumps({"suite": suite_name, "seed": seed, "variant": variant, "episodes": rows}, indent=1))
    outs = [r["outcome"] for r in rows]
    print(variant, suite_name, {o: outs.count(o) for o in ("reached_goal", "collided", "timed_out")})


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5])
