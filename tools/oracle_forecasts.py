"""Is it the forecast or the planner? The GPC with the walkers' true futures as its forecasts
(docs/crowds.md, "The cost of a slot"; docs/pedestrians.md, "Among 30 walkers: what a better
forecast would buy"; docs/buildings.md, "Told the walkers' future").

    python tools/oracle_forecasts.py --seed 1 --episodes 109,173 [--slots 6,10] [--std 0.05]
        [--suite circle-crossing] [--movers 10] [--behaviour orca] [--forecast truth|present]

Walkers that do not see the robot (the crowd and wall suites' default) move the same whatever
the robot does, so their positions at every future sample can be computed before the episode
(the simulator's own mover world, advanced sample by sample). The planner is then given those
positions as its forecasts instead of its EKF's, and runs behind its check layer as ``gpcnav
--controller gpc`` runs it (the same check settings), the rest of the planner as shipped for
the scene (its walls' slots, its crowd NLP). If it still collides, a better forecast of the
walkers would not have saved it.

``--forecast truth`` (the default): the true positions at steps 1..H, with a standard
deviation of ``--std`` (``--std filter``: with the filter's own covariances, so that only the
means are told; a small fixed deviation also lets the planner pass closer).
``--forecast present``: only the present known exactly: the true position now, carried on
straight at the true velocity of the last sample interval, with the filter's own covariances
(what a perfect sensor and a constant-velocity model would give; the robot's sensor has
0.02 m of noise). A walker about to leave the scene is forecast standing
where it leaves (:func:`true_positions`).

``--slots``: plan with one NLP of that many mover slots instead of the shipped ones (a comma
list runs each). Prints per slot count and episode the outcome, the smallest clearance, and
the worst clearance of its own plans against the true positions (negative: it planned into a
walker it knew about, or one left out of its NLP); and a summary line.
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
from casadi_gpc.safety import Shield  # noqa: E402
from casadi_gpc.types import ObstacleForecast  # noqa: E402
from gpcnav.commands.common import for_run  # noqa: E402
from gpcnav.controllers import check_settings  # noqa: E402
from scenarios import Suite  # noqa: E402
from scenarios.movers import MoverWorld  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402

GONE_M = 1e4
"""Where a walker that is never in the scene is put (far from everything)."""


def true_positions(scenario, sample_time_s: float, extra_steps: int, hold_absent: bool = True) -> np.ndarray:
    """The movers' positions at every sample, shape (samples, movers, 2), as the simulator
    moves them (walkers blind to the robot only). Where a walker is not in the scene (a track
    not yet begun or already ended) it is held where it enters or where it leaves: a forecast
    does not know that someone is about to vanish (carried off to far away, the planner was
    told that a walker beside it would go, and drove into it the sample before it did); one
    never in the scene is at :data:`GONE_M`. ``hold_absent`` False: NaN there, as the
    simulator gives it (what an offline study of forecasts wants)."""
    if any(getattr(m, "sees_robot", False) for m in scenario.moving):
        raise SystemExit("the walkers see the robot: their futures depend on it, no oracle")
    world = MoverWorld(scenario.moving, scenario.static, scenario.robot.radius_m, scenario.walls)
    n = int(scenario.duration_s / sample_time_s) + extra_steps + 2
    out = [world.positions(0.0)]
    for k in range(1, n):
        world.advance(k * sample_time_s, lambda t: (1e6, 1e6, 0.0, 0.0))  # a robot nobody sees
        out.append(world.positions(k * sample_time_s))
    out = np.array(out, dtype=float)
    if not hold_absent:
        return out
    for j in range(out.shape[1]):
        here = np.flatnonzero(np.isfinite(out[:, j]).all(axis=1))
        if not len(here):
            out[:, j] = GONE_M
            continue
        out[:here[0], j] = out[here[0], j]  # before it enters: where it enters
        for a, b in zip(here[:-1], here[1:]):  # a gap (none in the suites): where it left
            out[a + 1:b, j] = out[a, j]
        out[here[-1] + 1:, j] = out[here[-1], j]  # after it leaves: where it left
    return out


class OracleGPC(GPCController):
    """The GPC whose forecasts are the movers' true positions (``truth``, per sample)."""

    def use_truth(self, truth: np.ndarray, radii, std_m: float | None, present_only: bool = False) -> None:
        """``present_only``: the true position now carried on at the last interval's true
        velocity, with the filter's covariances (the module's ``--forecast present``);
        ``std_m`` None: the true future with the filter's covariances too."""
        self.truth, self.radii, self.present_only = truth, list(radii), present_only
        self.cov = None if std_m is None else np.tile(np.eye(2) * std_m ** 2, (self.config.horizon, 1, 1))

    def estimate(self, obs):
        own = super().estimate(obs)  # the filters run as usual (their counters, the covariances)
        H, k = self.config.horizon, int(round(obs.t_s / self.config.sample_time_s))
        if self.present_only:
            steps = np.arange(1, H + 1)[:, None]
            return [ObstacleForecast(f.obstacle_id, f.radius_m,
                                     self.truth[k, f.obstacle_id] + steps * (self.truth[k, f.obstacle_id]
                                                                            - self.truth[max(k - 1, 0), f.obstacle_id]),
                                     np.asarray(f.covs_m2)) for f in own]
        return [ObstacleForecast(f.obstacle_id, self.radii[f.obstacle_id],
                                 self.truth[k + 1:k + H + 1, f.obstacle_id].copy(),
                                 np.asarray(f.covs_m2) if self.cov is None else self.cov.copy()) for f in own]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--suite", default="circle-crossing")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--movers", type=int, default=10)
    ap.add_argument("--behaviour", default="orca")
    ap.add_argument("--episodes", default="109", help="comma-separated episode indices (from 0), or a range A-B")
    ap.add_argument("--slots", default="", help="comma-separated max_moving values (default: as shipped)")
    ap.add_argument("--std", default="0.05",
                    help="the true future's standard deviation, m, or 'filter': the filter's own covariances")
    ap.add_argument("--forecast", choices=("truth", "present"), default="truth")
    args = ap.parse_args(argv)
    try:
        if "-" in args.episodes:
            a, b = (int(v) for v in args.episodes.split("-"))
            episodes = list(range(a, b + 1))
        else:
            episodes = [int(e) for e in args.episodes.split(",")]
        std = None if args.std == "filter" else float(args.std)
        slot_counts = [int(s) for s in args.slots.split(",") if s]
    except ValueError as exc:
        ap.error(f"--episodes, --std or --slots: {exc}")
    if not episodes or min(episodes) < 0 or (std is not None and not std > 0) or any(n < 1 for n in slot_counts):
        ap.error("--episodes must name episodes from 0, --std be positive or 'filter', --slots at least 1")
    suite = Suite(args.suite, max(episodes) + 1, args.seed, args.movers, args.behaviour)
    outcomes = {}
    for slots in slot_counts or [None]:
        for i in episodes:
            sc = suite.scenario(i)
            cfg = for_run(preset("improved"), [sc])  # as the command line plans this scene
            if slots is not None:
                cfg = replace(cfg, max_moving=slots, crowd_moving=None)  # one NLP of that many slots
            T, H = cfg.sample_time_s, cfg.horizon
            truth = true_positions(sc, T, H)
            gpc = OracleGPC(cfg, sc.robot)
            gpc.use_truth(truth, [m.radius_m for m in sc.moving], std, args.forecast == "present")
            log = simulate(sc, Shield(gpc, sc.robot, check_settings("gpc", gpc, cfg, "on"), planner_config=cfg),
                           "gpc-oracle")
            recorded = np.array(log.obstacle_xy, dtype=float)[log.at_samples(), :len(sc.moving)]
            there = np.isfinite(recorded)
            assert np.array_equal(truth[:len(recorded)][there], recorded[there]), \
                "the oracle's positions are not the simulator's"
            worst = np.inf  # the worst clearance of the plans against the true positions
            radii = np.array([m.radius_m for m in sc.moving])
            for k, d in enumerate(log.decisions):
                if d.planned_poses is not None:
                    p = np.asarray(d.planned_poses)[:, None, :2]
                    gaps = np.hypot(*(truth[k + 1:k + H + 1] - p).transpose(2, 0, 1)) - (sc.robot.radius_m + radii)
                    worst = min(worst, float(gaps.min()))
            outcomes.setdefault(slots, []).append(log.outcome)
            print(f"slots {slots or 'shipped'}  episode {i:4d}: {log.outcome:12s} smallest clearance "
                  f"{log.min_clearance_m:6.3f} m, worst planned clearance against the truth {worst:6.3f} m", flush=True)
    for slots, got in outcomes.items():
        print(f"slots {slots or 'shipped'}, forecast {args.forecast}: " + ", ".join(
            f"{got.count(o)} {o}" for o in ("reached_goal", "collided", "timed_out")) + f" of {len(got)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
