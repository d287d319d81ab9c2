"""Is it the forecast or the planner? The GPC with the walkers' true futures as its forecasts
(docs/crowds.md, "The cost of a slot").

    python tools/oracle_forecasts.py --seed 1 --episodes 109,173 [--slots 6,10] [--std 0.05]
        [--suite circle-crossing] [--movers 10] [--behaviour orca]

Walkers that do not see the robot (the crowd suites' default) move the same whatever the
robot does, so their positions at every future sample can be computed before the episode
(the simulator's own mover world, advanced sample by sample). The planner is then given those
positions as its forecasts, with a small standard deviation (``--std``), instead of its EKF's,
and runs behind its check layer as ``gpcnav --controller gpc`` does. If it still collides, a
better forecast of the walkers would not have saved it. Prints per slot count and episode the
outcome, the smallest clearance, and the worst clearance of its own plans against the true
positions (negative: it planned into a walker it knew about, or one left out of its NLP).
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.planner.gpc import GPCController  # noqa: E402
from scenarios.movers import MoverWorld  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402
from casadi_gpc.types import ObstacleForecast  # noqa: E402
from casadi_gpc.safety import CheckSettings, Shield  # noqa: E402
from scenarios import Suite  # noqa: E402


def true_positions(scenario, sample_time_s: float, extra_steps: int) -> np.ndarray:
    """The movers' positions at every sample, shape (samples, movers, 2), as the simulator
    moves them (walkers blind to the robot only)."""
    if any(getattr(m, "sees_robot", False) for m in scenario.moving):
        raise SystemExit("the walkers see the robot: their futures depend on it, no oracle")
    world = MoverWorld(scenario.moving, scenario.static, scenario.robot.radius_m)
    n = int(scenario.duration_s / sample_time_s) + extra_steps + 2
    out = [world.positions(0.0)]
    for k in range(1, n):
        world.advance(k * sample_time_s, lambda t: (1e6, 1e6, 0.0, 0.0))  # a robot nobody sees
        out.append(world.positions(k * sample_time_s))
    return np.array(out)


class OracleGPC(GPCController):
    """The GPC whose forecasts are the movers' true positions (``truth``, per sample)."""

    def use_truth(self, truth: np.ndarray, radii, std_m: float) -> None:
        self.truth, self.radii = truth, list(radii)
        self.cov = np.tile(np.eye(2) * std_m ** 2, (self.config.horizon, 1, 1))

    def estimate(self, obs):
        self.bank.step(obs.moving)  # the filters run as usual (their counters), unused
        H, k = self.config.horizon, int(round(obs.t_s / self.config.sample_time_s))
        seen = {m.obstacle_id for m in obs.moving}
        return [ObstacleForecast(j, self.radii[j], self.truth[k + 1:k + H + 1, j].copy(), self.cov.copy())
                for j in range(len(self.radii)) if j in seen]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite", default="circle-crossing")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--movers", type=int, default=10)
    ap.add_argument("--behaviour", default="orca")
    ap.add_argument("--episodes", default="109")
    ap.add_argument("--slots", default="6,10", help="comma-separated max_moving values")
    ap.add_argument("--std", type=float, default=0.05, help="the oracle's forecast standard deviation, m")
    args = ap.parse_args(argv)
    suite = Suite(args.suite, 1, args.seed, args.movers, args.behaviour)
    for slots in (int(s) for s in args.slots.split(",")):
        cfg = replace(preset("improved"), max_moving=slots, crowd_moving=None)  # one NLP of that many slots
        T, H = cfg.sample_time_s, cfg.horizon
        for i in (int(e) for e in args.episodes.split(",")):
            sc = suite.scenario(i)
            truth = true_positions(sc, T, H)
            gpc = OracleGPC(cfg, sc.robot)
            gpc.use_truth(truth, [m.radius_m for m in sc.moving], args.std)
            log = simulate(sc, Shield(gpc, sc.robot, CheckSettings(trust_plans=True)), "gpc-oracle")
            recorded = np.array(log.obstacle_xy)[:, :len(sc.moving)]
            assert np.array_equal(truth[:len(recorded)], recorded), "the oracle's positions are not the simulator's"
            worst = np.inf  # the worst clearance of the plans against the true positions
            for k, d in enumerate(log.decisions):
                if d.planned_poses is not None:
                    p = np.asarray(d.planned_poses)[:, None, :2]
                    gaps = np.hypot(*(truth[k + 1:k + H + 1] - p).transpose(2, 0, 1))
                    gaps -= sc.robot.radius_m + np.array([m.radius_m for m in sc.moving])
                    worst = min(worst, float(gaps.min()))
            print(f"slots {slots:2d}  episode {i:4d}: {log.outcome:12s} smallest clearance "
                  f"{log.min_clearance_m:6.3f} m, worst planned clearance against the truth {worst:6.3f} m")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
