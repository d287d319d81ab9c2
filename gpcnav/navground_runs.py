"""navground's recorded experiments, summarised per behaviour: how many agents reached their
target, collided, ended stuck, and their efficacy.

``navground_py run EXPERIMENT.yaml`` writes ``<save_directory>/<name>_<hash>_<time>/data.h5``
(one group ``run_<i>`` per run, with the world's YAML as an attribute); this reads it with
h5py (``pip install h5py``; navground's own reader needs it too)::

    python -m gpcnav.navground_runs experiment_.../data.h5    # several: one table each

What each figure is, per agent and run (an "agent-run"):

- ``reached``: the agent's last waypoint (navground's ``Waypoints`` task, as Antipodal and
  Cross set it) came within its tolerance (its own in ``tolerances``, else ``tolerance``) at some
  step (with a looping task, at least once); ``time_to_target_s`` is the first such step's time (recorded poses);
- ``collided``: the agent is in at least one of navground's recorded collisions (any step,
  with anything);
- ``stuck``: navground's deadlock record is set at the end of the run (the agent had not
  moved for navground's deadlock time);
- ``efficacy``: navground's efficacy (the velocity towards the target over the optimal
  speed) averaged over the steps before the agent reached its target (after it, navground
  records 0), or over the whole run when it never did.

The experiment must record poses, collisions, efficacy and deadlocks and the world
(``record_pose``, ``record_collisions``, ``record_efficacy``, ``record_deadlocks``,
``record_world``).
"""
from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["AgentRun", "BehaviourSummary", "agent_runs", "summarise", "markdown", "RECORDS"]

RECORDS = {"record_world": ("'world'",), "record_deadlocks": ("'deadlocks'",), "record_collisions": ("'collisions'",),
           "record_efficacy": ("'efficacy'",), "record_pose": ("'poses'",)}
"""The experiment's records this reads, and the words of h5py's error where one is missing."""


@dataclass(frozen=True)
class AgentRun:
    """One agent in one recorded run."""

    run: int
    agent: int
    behaviour: str
    reached: bool | None
    """None: the agent has no waypoint."""
    time_to_target_s: float
    """nan when it never reached it."""
    collided: bool
    stuck: bool
    efficacy: float


@dataclass
class BehaviourSummary:
    """The agent-runs of one behaviour type."""

    behaviour: str
    agent_runs: int = 0
    reached: int = 0
    collided: int = 0
    stuck: int = 0
    efficacies: list[float] = field(default_factory=list)
    times_s: list[float] = field(default_factory=list)

    @property
    def mean_efficacy(self) -> float:
        return float(np.mean(self.efficacies)) if self.efficacies else math.nan

    @property
    def mean_time_to_target_s(self) -> float:
        return float(np.mean(self.times_s)) if self.times_s else math.nan


def _run_index(name: str) -> int:
    return int(name.rpartition("_")[2])


def _tolerance(task: dict, i: int) -> float:
    """The tolerance of waypoint ``i`` as navground's ``Waypoints`` task takes it: its own in
    ``tolerances`` where that list reaches it, else ``tolerance`` (the summary read ``tolerance``
    alone, 1 m by navground's default, so ``tolerances: [0.3]`` counted arrivals 0.7 m early)."""
    tolerances = task.get("tolerances") or []
    return float(tolerances[i] if i < len(tolerances) else task.get("tolerance", 0.0))


def agent_runs(path: str | Path) -> list[AgentRun]:
    """Every agent of every run recorded in ``path`` (navground's ``data.h5``)."""
    import h5py
    import yaml
    out = []
    with h5py.File(path, "r") as f:
        for name in sorted((k for k in f if k.startswith("run_")), key=_run_index):
            run = f[name]
            world = yaml.safe_load(run.attrs["world"])
            poses, efficacy = run["poses"][:], run["efficacy"][:]
            deadlocks, collisions = run["deadlocks"][:], run["collisions"][:]
            time_step = float(run.attrs["time_step"])
            hit = set(collisions[:, 1:].ravel().tolist()) if len(collisions) else set()
            for i, agent in enumerate(world["agents"]):
                task = agent.get("task") or {}
                waypoints = task.get("waypoints") or []
                reached, t_s, steps = None, math.nan, len(poses)
                if waypoints:
                    d = np.hypot(*(poses[:, i, :2] - np.asarray(waypoints[-1], dtype=float)).T)
                    within = d <= _tolerance(task, len(waypoints) - 1) + 1e-6
                    reached = bool(within.any())
                    if reached:
                        steps = int(np.argmax(within))
                        t_s = steps * time_step
                out.append(AgentRun(_run_index(name), i, agent["behavior"]["type"], reached, t_s, i in hit,
                                    bool(deadlocks[i] >= 0.0), float(np.mean(efficacy[:max(steps, 1), i]))))
    return out


def summarise(path: str | Path) -> list[BehaviourSummary]:
    """:func:`agent_runs` grouped by behaviour type, in the order they first appear."""
    groups: dict[str, BehaviourSummary] = {}
    for a in agent_runs(path):
        s = groups.setdefault(a.behaviour, BehaviourSummary(a.behaviour))
        s.agent_runs += 1
        s.reached += bool(a.reached)
        s.collided += a.collided
        s.stuck += a.stuck
        s.efficacies.append(a.efficacy)
        if a.reached:
            s.times_s.append(a.time_to_target_s)
    return list(groups.values())


def markdown(summaries: list[BehaviourSummary]) -> str:
    """The summaries as a Markdown table."""
    rows = ["| behaviour | agent-runs | reached | collided | stuck | efficacy (mean) | time to target (mean) |",
            "|---|---|---|---|---|---|---|"]
    for s in summaries:
        t = s.mean_time_to_target_s
        time_cell = f"{t:.1f} s" if t == t else "- (none reached)"
        rows.append(f"| {s.behaviour} | {s.agent_runs} | {s.reached} | {s.collided} | {s.stuck} | "
                    f"{s.mean_efficacy:.3f} | {time_cell} |")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m gpcnav.navground_runs", description=__doc__.split("\n\n")[0])
    parser.add_argument("data", type=Path, nargs="+",
                        help="navground's recorded data.h5 (several: one table each, under its name)")
    args = parser.parse_args(argv)
    tables = []
    for data in args.data:  # each read before anything is printed (experiment_*/data.h5 matched several
        try:                # folders after a second run, and was refused as unrecognized arguments)
            summaries = summarise(data)
        except (OSError, KeyError, ValueError) as exc:  # not there, not HDF5, not navground's layout
            what = str(exc)
            missing = [r for r, words in RECORDS.items() if any(w in what for w in words)] if data.is_file() else []
            hint = f"; record it in the experiment: {', '.join(f'{r}: true' for r in missing)}" if missing else ""
            print(f"{parser.prog}: error: {data}: cannot read navground's recorded runs ({what}){hint}",
                  file=sys.stderr)
            return 2
        if not summaries:
            print(f"{parser.prog}: error: {data}: no run recorded (an experiment that stopped before its first run)",
                  file=sys.stderr)
            return 2
        tables.append(markdown(summaries))
    if len(tables) == 1:
        print(tables[0])
    else:
        print("\n\n".join(f"{data}:\n\n{table}" for data, table in zip(args.data, tables)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
