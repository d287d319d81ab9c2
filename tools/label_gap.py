"""How far a cold label is from the closed-loop label (the command the GPC gives in closed loop), in the same situations.

The GPC drives a suite's episodes bare, recorded as `gpcnav dataset --dagger gpc --labels
closed-loop` records them (:class:`~nn_export.training.dataset.onpolicy.Recorder` with a
shadow GPC: its label is the driving GPC's command, bit for bit,
``tests/test_closed_loop_labels.py``); every situation is also labelled as `gpcnav dataset`
labels from cold (the multi-start from the fixed guesses, no kept candidate), and the largest
wheel-speed difference between the two is reported: over all situations, and over those with
a person within 2 m of the robot. What `--labels closed-loop` (docs/buildings.md, "The
network reads walls") is for.

Usage: ``python tools/label_gap.py --suite corner --count 4 [--seed 2000] [--movers 5]``
"""
from __future__ import annotations

import argparse

import numpy as np

from casadi_gpc.config import preset
from casadi_gpc.planner.gpc import GPCController
from casadi_gpc.robot import RobotParams
from nn_export.training.dataset.onpolicy import Recorder
from nn_export.training.labels import Labeller
from scenarios import Suite
from scenarios.simulator import simulate

WALL_SUITES = ("corridor", "doorway", "corner")


def summary(gaps: np.ndarray) -> str:
    return (f"{len(gaps)} situations: median {np.median(gaps):.3f} m/s, p90 {np.percentile(gaps, 90):.3f}, "
            f"over 0.1 m/s {np.mean(gaps > 0.1):.1%}, over 0.3 m/s {np.mean(gaps > 0.3):.1%}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite", required=True)
    ap.add_argument("--count", type=int, default=4)
    ap.add_argument("--seed", type=int, default=2000)
    ap.add_argument("--movers", type=int, default=5)
    args = ap.parse_args()
    cfg = preset("improved").for_walls(args.suite in WALL_SUITES)
    robot = RobotParams()
    recorder = Recorder(GPCController(cfg, robot), cfg, shadow=GPCController(cfg, robot))
    labeller = Labeller(cfg)
    gaps, nearest = [], []
    for scenario in Suite(args.suite, args.count, args.seed, args.movers, "orca").scenarios():
        log = simulate(scenario, recorder, scenario.name)
        for situation, closed_loop in recorder.situations:
            cold = labeller.label(situation)
            if not (cold.converged and closed_loop.converged):
                continue
            gaps.append(float(np.max(np.abs(closed_loop.wheels_mps - cold.wheels_mps))))
            robot_xy = np.array([situation.robot.x_m, situation.robot.y_m])
            nearest.append(min((float(np.hypot(*(t.state[:2] - robot_xy))) for t in situation.tracks), default=np.inf))
        print(f"{scenario.name}: {log.outcome}, {len(recorder.situations)} decisions")
    gaps, nearest = np.array(gaps), np.array(nearest)
    print("all:", summary(gaps))
    if np.any(nearest < 2.0):
        print("a person within 2 m:", summary(gaps[nearest < 2.0]))


if __name__ == "__main__":
    main()
