"""How much of the planner's record among replayed people is the forecast's: the GPC with its
own forecast beside the GPC told the recording's future, on the same cases.

A study instrument, not a controller: the recording's future is what no robot knows. It
separates what the recording forces (a robot standing still is hit; people who cannot give
way walk into whatever is in their path) from what the planner does with what it can know.
The planner, its check layer and everything else are the shipped ones (``gpcnav evaluate
--controller gpc``); only the obstacle forecasts it plans and is checked with are replaced,
per decision (the check reads the planner's forecasts):

- ``own``: the shipped forecast (the obstacle EKF, straight under ``improved``);
- ``people-noise``: the shipped filter with process noises that cover people's motion
  (:data:`PEOPLE_NOISE`: the recorded positions fall within two standard deviations of its
  forecast 0.87 to 0.95 of the time on the shipped recordings, against 0.22 to 0.62 with the
  shipped noises; ``tools/forecast_accuracy.py --speed-noise 0.3 --heading-noise 0.05``);
- ``constant-velocity``: Schöller et al.'s model on the robot's own measurements: the last
  measured displacement over one sample, repeated, with the shipped forecast's uncertainty
  (it predicts people better than the filter, ``tools/forecast_accuracy.py``);
- ``recording``: each person's recorded positions at the H sample instants ahead, with no
  uncertainty (a perfect forecast);
- ``next-sample``: the recorded position one sample ahead, then straight on at the recorded
  velocity over that sample, with the shipped forecast's uncertainty (half a second of the
  future: a person's next step, no more);
- ``stand``: the robot that stands still (the baseline every table on recorded people has).

Usage: ``python tools/forecast_bound.py [FILE ...] [--count 40] [--seed 1] [--out BOUND.json]
[--rows stand,own,...] [--younger-than S]`` (the ``ucy`` suite, people replayed open loop;
``FILE``: scenario files of replayed people instead, e.g. ``gpcnav import-tracks``' cases of
another recording; ``--younger-than``: the recording told only of people in the scene for less than S
seconds). Prints a Markdown table.
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.io import write_json  # noqa: E402
from gpcnav.controllers import make_controller  # noqa: E402
from scenarios import load_scenario  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402
from scenarios.suites import Suite  # noqa: E402

FORECASTS = ("own", "people-noise", "constant-velocity", "recording", "next-sample")
PEOPLE_NOISE = {"speed_noise_mps2": 0.3, "heading_noise_rad": 0.05}
APPEARED_S = 1.0
"""A collision with someone in the scene for less than this is one they appeared on the robot
(the contract's ``obstacle_age_s``, G-MPC's ghost time)."""


def told_the_recording(planner, scenario, mode: str, younger_than_s: float | None = None) -> None:
    """Replace ``planner.estimate`` (the GPC's forecasts, which its check reads too) by the
    recording's future of each person it tracks (``mode`` as the module text says); with
    ``younger_than_s``, only of the people in the scene for less than that (since their
    track's first row), the others keep the planner's own forecast."""
    own = planner.estimate
    H, T = planner.config.horizon, planner.config.sample_time_s

    def estimate(obs):
        out = []
        for f in own(obs):
            track = scenario.moving[f.obstacle_id]
            if younger_than_s is not None and obs.t_s - track.times_s[0] >= younger_than_s:
                out.append(f)
                continue
            ahead = np.asarray(track.recorded_at(obs.t_s + T * np.arange(1, H + 1)), dtype=float)
            if mode == "recording":
                out.append(replace(f, means_m=ahead, covs_m2=np.zeros((H, 2, 2))))
            else:
                step = ahead[0] - np.asarray(track.recorded_at(obs.t_s), dtype=float)
                means = ahead[0] + step * np.arange(H)[:, None]
                out.append(replace(f, means_m=means))
        return out

    planner.estimate = estimate


def constant_velocity(planner) -> None:
    """Replace ``planner.estimate``'s means by the constant-velocity model on the measurements:
    each person's last measured displacement over one sample, repeated (a person measured once,
    or not at the previous sample, keeps the planner's own forecast)."""
    own = planner.estimate
    H, T = planner.config.horizon, planner.config.sample_time_s
    last: dict[int, tuple[float, np.ndarray]] = {}

    def estimate(obs):
        now = {m.obstacle_id: np.asarray(m.position_m, dtype=float) for m in obs.moving if m.position_m is not None}
        out = []
        for f in own(obs):
            before, z = last.get(f.obstacle_id), now.get(f.obstacle_id)
            if z is None or before is None or abs(obs.t_s - before[0] - T) > 1e-6:
                out.append(f)
            else:
                out.append(replace(f, means_m=z + (z - before[1]) * np.arange(1, H + 1)[:, None]))
        last.clear()
        last.update({i: (obs.t_s, z) for i, z in now.items()})
        return out

    planner.estimate = estimate


def run(count: int, seed: int, preset_name: str, rows_wanted=("stand",) + FORECASTS,
        younger_than_s: float | None = None, scenarios=None, files=None) -> dict:
    """``scenarios``: the scenarios of scenario files (people replayed open loop; ``files``
    their paths, for the record) instead of the ``ucy`` suite's ``count`` cases of ``seed``."""
    if scenarios is None:
        suite = Suite("ucy", count=count, seed=seed, behaviour="replay")
        scenarios = [suite.scenario(i) for i in range(count)]
    config = preset(preset_name)
    rows = {}
    for name in rows_wanted:
        episodes = []
        for sc in scenarios:
            ctl = make_controller("stand" if name == "stand" else "gpc", config, sc.robot)
            if name in ("recording", "next-sample"):
                told_the_recording(ctl.policy, sc, name, younger_than_s)
            elif name == "constant-velocity":
                constant_velocity(ctl.policy)
            elif name == "people-noise":
                ctl.policy.ekf_settings = replace(ctl.policy.ekf_settings, **PEOPLE_NOISE)
            log = simulate(sc, ctl, name)
            c = log.collision or {}
            episodes.append({"scenario": sc.name, "outcome": log.outcome,
                             "appeared": bool(c) and c.get("obstacle_age_s", 0.0) < APPEARED_S,
                             "approaching": bool(c) and c.get("robot_speed_towards_mps", 0.0) > 0.05
                             and c.get("obstacle_age_s", 0.0) >= APPEARED_S})
        rows[name] = {"reached": sum(e["outcome"] == "reached_goal" for e in episodes),
                      "collided": sum(e["outcome"] == "collided" for e in episodes),
                      "appeared": sum(e["appeared"] for e in episodes),
                      "approaching": sum(e["approaching"] for e in episodes),
                      "timed_out": sum(e["outcome"] == "timed_out" for e in episodes), "episodes": episodes}
    return {"suite": "ucy" if files is None else "files", "behaviour": "replay", "count": len(scenarios),
            "seed": seed if files is None else None, "files": files, "preset": preset_name,
            "told_only_people_in_view_less_than_s": younger_than_s, "forecasts": rows}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenarios", nargs="*", type=Path,
                    help="scenario files of replayed people (e.g. gpcnav import-tracks' cases) "
                         "instead of the ucy suite")
    ap.add_argument("--count", type=int, default=40)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--preset", default="improved")
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--rows", default=",".join(("stand",) + FORECASTS),
                    help="which robots, comma-separated (default: all)")
    ap.add_argument("--younger-than", type=float, default=None, metavar="S",
                    help="tell the recording only of people in the scene for less than S seconds")
    args = ap.parse_args(argv)
    wanted = tuple(r for r in args.rows.split(",") if r)
    unknown = [r for r in wanted if r not in ("stand",) + FORECASTS]
    if unknown or not wanted:
        ap.error(f"--rows: unknown {', '.join(unknown) or '(none given)'} (choose from stand, {', '.join(FORECASTS)})")
    if args.younger_than is not None and not args.younger_than > 0:
        ap.error(f"--younger-than must be positive, got {args.younger_than}")
    scenarios = None
    if args.scenarios:
        scenarios = []
        for path in args.scenarios:
            try:
                sc = load_scenario(path)
            except ValueError as exc:  # scenarios.ScenarioError: one line naming the file
                ap.error(str(exc))
            if not sc.moving or not all(getattr(m, "behaviour", None) == "replay" for m in sc.moving):
                ap.error(f"{path}: not a case of people replayed open loop "
                         f"(every mover a track with behaviour = \"replay\")")
            scenarios.append(sc)
    doc = run(args.count, args.seed, args.preset, wanted, args.younger_than, scenarios,
              [str(p) for p in args.scenarios] or None)
    what = f"{len(scenarios)} scenario files" if scenarios else f"ucy, {args.count} cases, seed {args.seed}"
    print(f"{what}, replayed, {args.preset}\n")
    print("| robot | reached | collided | of which appeared on it (< 1 s) | of which robot approaching | timed out |")
    print("|---|---|---|---|---|---|")
    for name, r in doc["forecasts"].items():
        label = "stands still" if name == "stand" else f"GPC, forecast: {name}"
        print(f"| {label} | {r['reached']} | {r['collided']} | {r['appeared']} | {r['approaching']} | {r['timed_out']} |")
    if args.out is not None:
        write_json(args.out, doc)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
