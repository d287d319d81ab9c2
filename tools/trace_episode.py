"""Why an episode ended as it did: one episode run again, decision by decision, with what the
controller saw and chose, around a moment (by default the last seconds before its collision).

For each decision in the window: the time, the robot's pose and speed, the command (speed and
turn rate) and whether the check layer replaced it, with its reason (the check's own words:
which obstacle failed the margin, and which manoeuvre it took); then, for each mover followed
(the one the robot collided with, or ``--mover``), its true position and distance, what the
sensor measured of it, and every forecast the decision was made with for it (the track, and a
ghost while a gated measurement waits: its first steps and their standard deviation).

    python tools/trace_episode.py SCENARIO.toml [--controller gpc|nn] [--window 4] [--mover 3,9]
    python tools/trace_episode.py --suite ucy --count 452 --seed 1 --index 249
    python tools/trace_episode.py --suite corridor --seed 1 --index 172 --from 12 --to 16

The controller is made as ``gpcnav evaluate`` makes it (the preset, the wall slots and the
crowd NLP its scenario needs, behind its default check layer), so a collision of an
evaluation is reproduced here (the decisions are deterministic; the solve lanes change how
fast the planner answers, never what). A scenario that cannot be read is a one-line error,
exit 2.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def run(scenario, controller: str = "gpc", preset_name: str = "improved"):
    """Simulate ``scenario`` with ``controller`` as ``gpcnav evaluate`` would; the RunLog and,
    per decision, the observation and the decision."""
    from casadi_gpc.config import preset
    from gpcnav.commands.common import for_run
    from gpcnav.controllers import ControllerSpec, check, make
    from scenarios.simulator import simulate
    spec, config = ControllerSpec(controller), for_run(preset(preset_name), [scenario])
    check(spec, config, scenario.robot)
    inner = make(spec, config, scenario.robot)
    seen = []

    class Recorder:  # the controller, its observations and decisions kept
        sample_time_s = inner.sample_time_s

        def __getattr__(self, name):
            return getattr(inner, name)

        def reset(self):
            inner.reset()

        def decide(self, obs):
            d = inner.decide(obs)
            seen.append((obs, d))
            return d

    log = simulate(scenario, Recorder(), spec.label)
    return log, seen


def rows(log, seen, movers=(), start_s=-math.inf, end_s=math.inf) -> list[dict]:
    """The decisions between ``start_s`` and ``end_s`` (s) as dicts (module docstring), each
    with the followed ``movers`` (indices of the scenario's moving obstacles)."""
    out = []
    for k, (obs, dec) in enumerate(seen):
        t = log.t[k]
        if not start_s - 1e-9 <= t <= end_s + 1e-9:
            continue
        x, y, th, vr, vl = log.states[k]
        row = {"t_s": float(t), "robot": (float(x), float(y), float(th)), "speed_mps": float((vr + vl) / 2),
               "command": (float((dec.v_right_mps + dec.v_left_mps) / 2), float(dec.v_right_mps - dec.v_left_mps)),
               "replaced": bool(dec.fallback), "reason": dec.reason, "movers": []}
        for j in movers:
            p = log.obstacle_xy[k][j]
            oid = j  # the simulator's sensor gives the i-th mover the id i
            meas = [tuple(map(float, m.position_m)) for m in obs.moving if m.obstacle_id == oid
                    and m.position_m is not None]
            fcs = [{"means_m": np.asarray(f.means_m)[:3].round(3).tolist(),
                    "first_std_m": np.sqrt(np.diag(np.asarray(f.covs_m2)[0])).round(3).tolist()}
                   for f in (dec.forecasts or ()) if f.obstacle_id == oid]
            row["movers"].append({"index": int(j), "position_m": (float(p[0]), float(p[1])),
                                  "distance_m": float(math.hypot(p[0] - x, p[1] - y)),
                                  "measured_m": meas, "forecasts": fcs})
        out.append(row)
    return out


def text(log, trace: list[dict]) -> str:
    """The trace as lines to read."""
    hit = ", ".join(f"{k} {round(float(v), 3) if isinstance(v, (float, np.floating)) else v}"
                    for k, v in (log.collision or {}).items())
    lines = [f"{log.scenario.name}: {log.outcome}" + (f" ({hit})" if hit else "")]
    for r in trace:
        x, y, th = r["robot"]
        v, w = r["command"]
        lines.append(f"t={r['t_s']:6.2f} robot ({x:6.2f}, {y:6.2f}) heading {th:5.2f} speed {r['speed_mps']:5.2f} | "
                     f"command {v:5.2f} m/s {w:5.2f} rad/s{' REPLACED' if r['replaced'] else ''}: {r['reason']}")
        for m in r["movers"]:
            px, py = m["position_m"]
            head = f"    mover {m['index']} at " + ("(not in the scene)" if math.isnan(px) else
                                                   f"({px:.2f}, {py:.2f}), {m['distance_m']:.2f} m away")
            lines.append(head + f"; measured {[tuple(round(c, 2) for c in z) for z in m['measured_m']]}")
            for f in m["forecasts"]:
                lines.append(f"      forecast {f['means_m']} (first step's std {f['first_std_m']})")
    return "\n".join(lines)


def main(argv=None) -> int:
    from casadi_gpc.config import PRESETS
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scenario", nargs="?", help="a scenario file (TOML); or --suite")
    ap.add_argument("--suite", help="a seeded suite's episode instead (with --index)")
    ap.add_argument("--count", type=int, default=200, help="the suite's count (default 200)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--movers", type=int, default=5, help="a crowd suite's movers (default 5)")
    ap.add_argument("--behaviour", default=None, help="the suite's movers' behaviour (default the suite's)")
    ap.add_argument("--index", type=int, default=0, help="which episode of the suite (default 0)")
    ap.add_argument("--controller", default="gpc")
    ap.add_argument("--preset", default="improved", choices=tuple(PRESETS))
    ap.add_argument("--mover", default=None, help="comma-separated mover indices to follow (default: the one hit)")
    ap.add_argument("--window", type=float, default=4.0, help="seconds before the collision, or the end (default 4)")
    ap.add_argument("--from", dest="start", type=float, default=None, help="start of the window, s")
    ap.add_argument("--to", dest="end", type=float, default=None, help="end of the window, s")
    a = ap.parse_args(argv)
    try:
        if (a.scenario is None) == (a.suite is None):
            raise ValueError("give a scenario file or --suite, not both or neither")
        if a.suite is not None:
            from scenarios.suites import Suite
            sc = Suite(a.suite, a.count, a.seed, a.movers, a.behaviour).scenario(a.index)
        else:
            from scenarios import load_scenario
            sc = load_scenario(a.scenario)
        movers = [int(v) for v in a.mover.split(",")] if a.mover else []
        if any(not 0 <= j < len(sc.moving) for j in movers):
            raise ValueError(f"--mover: the scenario has movers 0 to {len(sc.moving) - 1}")
    except (OSError, ValueError) as exc:
        print(f"trace_episode: {str(exc).splitlines()[0]}", file=sys.stderr)
        return 2
    from gpcnav.errors import UsageError
    try:
        log, seen = run(sc, a.controller, a.preset)
    except UsageError as exc:  # (a name of no controller, one that cannot drive the robot: it was a traceback)
        print(f"trace_episode: {exc}", file=sys.stderr)
        return 2
    if not movers and log.collision and log.collision.get("obstacle") == "moving":
        movers = [int(log.collision["index"])]
    end = a.end if a.end is not None else (log.collision["time_s"] if log.collision else log.t[len(seen) - 1])
    start = a.start if a.start is not None else end - a.window
    print(text(log, rows(log, seen, movers, start, end)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
