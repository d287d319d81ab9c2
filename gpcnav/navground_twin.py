"""A gpcnav scenario run inside navground's own simulator: the reverse check of the peers.

gpcnav runs navground's ORCA and HRVO as controllers of its robot (``gpcnav.peers``) in its
own simulator. This module runs the very same scenario file in navground's simulator
(``navground.sim.World``), with the robot a navground agent driven by navground's behaviour
as a navground user would set it up, and the walkers navground agents set up as
:mod:`scenarios.movers` sets them up:

- **the robot**: an agent of the robot's radius with navground's two-wheel kinematics (wheel
  axis = the wheel base, maximal speed = the wheel limit; ``2WDiffDyn`` with the wheels'
  acceleration limit unless ``acceleration_limit=False``), the behaviour (``ORCA``, ``HRVO``,
  or any registered type, ``GPC`` included) with the reference speed as ``optimal_speed``,
  the wheel limit as ``max_speed``, the safety margin, and a ``Waypoints`` task to the end of
  the reference path; it sees every walker exactly, within the behaviour's ``horizon``;
- **the walkers** (``orca`` / ``social_force`` movers with a goal): holonomic (``Omni``)
  agents with their radius, preferred speed, navground's behaviour, the movers' safety
  margin, a ``Waypoints`` task to their goal; each sees the others within
  :data:`scenarios.movers.PERCEPTION_RANGE_M` (a walker standing at its goal as a disc, as in
  gpcnav's simulator), and the robot only if it ``sees_robot``
  (:class:`WalkerSight`, a navground state estimation);
- every agent decides every :data:`CONTROL_PERIOD_S` (0.1 s, the walkers' grid in gpcnav),
  navground integrates at :data:`TIME_STEP_S`.

The outcome is gpcnav's (``docs/scenarios.md``, "Episodes"): *collided* at the first
integration step where the robot's disc overlaps a walker's or a static disc (navground's
own collision record: navground detects the overlap during the step, then pushes the discs
apart, so the positions after the step no longer show it); *reached goal*
once the reference has reached the end of the path and the robot is within 0.3 m of it;
else *timed out* at the scenario's ``duration_s``. Scenarios with constant or recorded
movers, or walls, are refused (the walkers and static discs are what the peers' check needs).

``python -m gpcnav.navground_twin FILE.toml ... --behaviour ORCA [--workers 2] [--out X.json]``
prints the counts with their 95 % Clopper-Pearson intervals.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["TwinSettings", "TwinOutcome", "run_twin", "WalkerSight", "CONTROL_PERIOD_S", "TIME_STEP_S", "ROBOT_ID"]

CONTROL_PERIOD_S = 0.1
"""Every agent's control period: the walkers' decision grid of gpcnav's simulator, and the
peers' sample time."""
TIME_STEP_S = 0.02
"""navground's integration step: five per decision, so that a collision between decisions is
seen (gpcnav checks ten instants per sample interval)."""
ROBOT_ID = 1_000_000
"""The robot agent's id (what :class:`WalkerSight` leaves out for walkers that do not see
it)."""
GOAL_TOLERANCE_M = 0.3
"""gpcnav's goal rule."""


@dataclass(frozen=True)
class TwinSettings:
    """How the robot is set up inside navground."""

    behaviour: str = "ORCA"
    """navground's behaviour type of the robot."""
    safety_margin_m: float = 0.15
    """navground's ``safety_margin`` (the contract's 0.15 m)."""
    horizon_m: float = 10.0
    """navground's ``horizon`` of the robot's behaviour and the robot's sensing range."""
    acceleration_limit: bool = True
    """``2WDiffDyn`` with the wheels' acceleration limit (``max_acceleration`` = the limit,
    ``moi`` = 2: then navground's bound, |dv| + |dw| W moi / 4 <= a dt, is exactly every
    wheel's |dv_wheel| <= a dt); else ``2WDiff`` (no acceleration limit)."""
    goal_tolerance_m: float = 0.1
    """The robot's ``Waypoints`` tolerance (navground stops the robot there); inside gpcnav's
    0.3 m, as the peers' own ``goal_tolerance_m``."""
    properties: dict = field(default_factory=dict)
    """More properties of the behaviour (``Behavior.set``), e.g. ``{"time_horizon": 5.0}``."""
    blind_walkers_see_robot: bool = False
    """Override: walkers that do not see the robot in the scenario see it here (to measure
    what the reciprocity costs)."""


@dataclass(frozen=True)
class TwinOutcome:
    name: str
    outcome: str
    end_time_s: float
    min_clearance_m: float
    path_m: float


def _walker_sight_class():
    from navground import core, sim

    from scenarios.movers import PERCEPTION_RANGE_M

    class _WalkerSight(sim.StateEstimation, name="GpcnavWalkerSight"):
        """What a walker of gpcnav's simulator sees: every other agent within
        ``range`` (centre distance), an agent idle at its goal as a disc, and the robot only
        if ``sees_robot``."""

        def __init__(self, sees_robot: bool = False, range: float = PERCEPTION_RANGE_M):
            super().__init__()
            self._sees_robot = bool(sees_robot)
            self._range = float(range)

        def update(self, agent, world, state) -> None:
            neighbours, discs = [], [core.Disc(d.disc.position, d.disc.radius) for d in world.discs]
            p = np.asarray(agent.position, dtype=float)
            for other in world.agents:
                if other is agent or (other.id == ROBOT_ID and not self._sees_robot):
                    continue
                q = np.asarray(other.position, dtype=float)
                if math.hypot(*(q - p)) > self._range:
                    continue
                if other.id != ROBOT_ID and other.idle:
                    discs.append(core.Disc(q, other.radius))
                else:
                    neighbours.append(core.Neighbor(q, other.radius, np.asarray(other.velocity, dtype=float), other.id))
            state.neighbors = neighbours
            state.static_obstacles = discs

    return _WalkerSight


_SIGHT = None


def WalkerSight(sees_robot: bool = False):
    """navground's state estimation of one walker (made on first use: it imports navground)."""
    global _SIGHT
    if _SIGHT is None:
        _SIGHT = _walker_sight_class()
    return _SIGHT(sees_robot)


def _robot_agent(scenario, settings: TwinSettings):
    from navground import core, sim
    r, start = scenario.robot, scenario.robot_start
    if settings.acceleration_limit:
        kin = core.Kinematics.make_type("2WDiffDyn")
        kin.set("max_acceleration", r.max_wheel_accel_mps2)
        kin.set("moi", 2.0)
    else:
        kin = core.Kinematics.make_type("2WDiff")
    kin.set("wheel_axis", r.wheel_base_m)
    kin.max_speed = r.max_wheel_speed_mps
    if settings.behaviour not in core.Behavior.types:
        core.load_plugins()  # GPC, GPCNetwork: gpcnav's own behaviours
    from .navground_plugin import GPCBehavior
    if isinstance(core.Behavior.make_type(settings.behaviour), GPCBehavior):
        kin.set("max_backward_speed", r.max_wheel_speed_mps)  # gpcnav's robot reverses (docs/navground.md)
    b = core.Behavior.make_type(settings.behaviour)
    b.kinematics = kin
    b.radius = r.radius_m
    b.safety_margin = settings.safety_margin_m
    b.horizon = settings.horizon_m
    b.optimal_speed = scenario.reference.speed_mps
    b.max_speed = r.max_wheel_speed_mps
    for name, value in settings.properties.items():
        if not b.has(name):
            raise ValueError(f"navground's {settings.behaviour} has no property {name!r}")
        b.set(name, value)
    goal = np.asarray(scenario.reference.end_pose[:2], dtype=float)
    task = sim.tasks.WaypointsTask([goal], loop=False, tolerance=settings.goal_tolerance_m)
    se = sim.state_estimations.BoundedStateEstimation(range=settings.horizon_m)
    agent = sim.Agent(radius=r.radius_m, behavior=b, kinematics=kin, task=task, state_estimations=[se],
                      control_period=CONTROL_PERIOD_S, id=ROBOT_ID)
    agent.position = np.array((start.x_m, start.y_m))
    agent.orientation = start.heading_rad
    return agent


def _walker_agent(mover, index: int, sees_robot: bool):
    from navground import core, sim

    from scenarios.movers import BEHAVIOURS, GOAL_TOLERANCE_M, MOVER_SAFETY_MARGIN_M
    kin = core.Kinematics.make_type("Omni")
    kin.max_speed = mover.preferred_speed_mps
    b = core.Behavior.make_type(BEHAVIOURS[mover.behaviour])
    b.kinematics = kin
    b.radius = mover.radius_m
    b.max_speed = b.optimal_speed = mover.preferred_speed_mps
    b.safety_margin = MOVER_SAFETY_MARGIN_M
    task = sim.tasks.WaypointsTask([np.asarray(mover.goal_m, dtype=float)], loop=False, tolerance=GOAL_TOLERANCE_M)
    agent = sim.Agent(radius=mover.radius_m, behavior=b, kinematics=kin, task=task,
                      state_estimations=[WalkerSight(sees_robot)], control_period=CONTROL_PERIOD_S, id=index)
    agent.position = np.asarray(mover.position_m, dtype=float)
    goal = np.asarray(mover.goal_m, dtype=float) - agent.position
    agent.orientation = math.atan2(goal[1], goal[0])
    return agent


def twin_world(scenario, settings: TwinSettings):
    """navground's world of ``scenario``: the robot agent first, then the walkers."""
    from navground import core, sim
    if getattr(scenario, "walls", ()):
        raise ValueError(f"{scenario.name}: walls are not exported to navground")
    world = sim.World()
    world.add_agent(_robot_agent(scenario, settings))
    for j, m in enumerate(scenario.moving):
        if getattr(m, "behaviour", "constant") not in ("orca", "social_force") or hasattr(m, "track"):
            raise ValueError(f"{scenario.name}: mover {j} is not a walker with a goal")
        world.add_agent(_walker_agent(m, j, m.sees_robot or settings.blind_walkers_see_robot))
    for s in scenario.static:
        world.add_obstacle(core.Disc(np.asarray(s.position_m, dtype=float), s.radius_m))
    return world


def run_twin(scenario, settings: TwinSettings = TwinSettings()) -> TwinOutcome:
    """Run ``scenario`` in navground's simulator (module docstring) and judge it by gpcnav's
    rules."""
    world = twin_world(scenario, settings)
    robot, *walkers = world.agents
    radii = np.array([w.radius for w in walkers] + [s.radius_m for s in scenario.static], dtype=float)
    statics = np.array([s.position_m for s in scenario.static], dtype=float).reshape(-1, 2)
    R = scenario.robot.radius_m
    end = np.asarray(scenario.reference.end_pose[:2], dtype=float)
    n = int(math.floor(scenario.duration_s / TIME_STEP_S + 1e-9))
    min_gap, path, last = math.inf, 0.0, np.asarray(robot.position, dtype=float)
    outcome, t = "timed_out", n * TIME_STEP_S
    for k in range(1, n + 1):
        world.update(TIME_STEP_S)
        p = np.asarray(robot.position, dtype=float)
        path += math.hypot(*(p - last))
        last = p
        if radii.size:
            xy = np.concatenate([np.array([w.position for w in walkers], dtype=float).reshape(-1, 2), statics])
            gap = float(np.min(np.hypot(*(xy - p).T) - radii - R))
            min_gap = min(min_gap, gap)
            # navground detects overlaps during the step and then pushes the discs apart, so
            # after the step the gap reads >= 0: its record is the check
            if gap < 0.0 or robot.last_collision_time >= 0.0:
                min_gap = min(min_gap, gap, 0.0)
                outcome, t = "collided", k * TIME_STEP_S
                break
        if k * TIME_STEP_S >= scenario.reference.duration_s - 1e-9 and math.hypot(*(p - end)) <= GOAL_TOLERANCE_M:
            outcome, t = "reached_goal", k * TIME_STEP_S
            break
    return TwinOutcome(scenario.name, outcome, round(t, 6), min_gap, path)


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """Two-sided Clopper-Pearson interval of a proportion ``k / n``."""
    from scipy.stats import beta
    a = 1.0 - level
    lo = 0.0 if k == 0 else float(beta.ppf(a / 2, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a / 2, k + 1, n - k))
    return lo, hi


def _refusal(paths, settings: TwinSettings) -> str | None:
    """Why these files and settings cannot run (one line), or None: a file that is not a
    scenario, one with walls or with movers that are not walkers with goals (navground's world
    of it cannot be built), a behaviour navground does not know."""
    from navground import core

    from scenarios import load_scenario
    from scenarios.loader import ScenarioError
    if settings.behaviour not in core.Behavior.types:
        core.load_plugins()  # GPC, GPCNetwork: gpcnav's own behaviours
    if settings.behaviour not in core.Behavior.types:
        return f"--behaviour {settings.behaviour!r}: not a navground behaviour (choose from " \
               f"{', '.join(sorted(t for t in core.Behavior.types if t))})"
    behaviour = core.Behavior.make_type(settings.behaviour)
    for name in settings.properties:  # (it was run_twin's ValueError, a traceback)
        if not behaviour.has(name):
            return f"--set {name}: navground's {settings.behaviour} has no property {name!r}"
    for path in paths:
        try:
            sc = load_scenario(path)
        except ScenarioError as exc:
            return str(exc)
        if getattr(sc, "walls", ()):
            return f"{path}: walls are not exported to navground"
        for j, m in enumerate(sc.moving):
            if getattr(m, "behaviour", "constant") not in ("orca", "social_force") or hasattr(m, "track"):
                return f"{path}: mover {j} is not a walker with a goal (navground's twin takes navground's scenes, " \
                       f"tools/export_navground_scenario.py)"
    return None


def _properties(items) -> dict | str:
    """``--set NAME=VALUE`` items as the behaviour's properties (a number, or true / false), or
    why one cannot be (one line: a bad value was a traceback)."""
    props = {}
    for item in items:
        name, eq, value = (part.strip() for part in item.partition("="))
        if not eq or not name:
            return f"--set takes NAME=VALUE, got {item!r}"
        if value.lower() in ("true", "false"):
            props[name] = value.lower() == "true"
            continue
        try:
            props[name] = float(value)
        except ValueError:
            return f"--set {name}: a number or true / false, got {value!r}"
        if not math.isfinite(props[name]):
            return f"--set {name}: must be finite, got {value!r}"
    return props


def _run_one(args):
    path, settings = args
    from scenarios import load_scenario
    return run_twin(load_scenario(path), settings)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m gpcnav.navground_twin", description=__doc__.split("\n\n")[0])
    p.add_argument("scenarios", nargs="+", type=Path)
    p.add_argument("--behaviour", default="ORCA", help="navground's behaviour type of the robot (ORCA, HRVO, ...)")
    p.add_argument("--safety-margin", type=float, default=0.15)
    p.add_argument("--no-acceleration-limit", action="store_true", help="2WDiff instead of 2WDiffDyn")
    p.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                   help="a property of the robot's behaviour (float, or true/false)")
    p.add_argument("--walkers-see-robot", action="store_true", help="every walker sees the robot")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--out", type=Path, help="JSON file of the outcomes")
    a = p.parse_args(argv)
    props, bad = _properties(a.set), None
    if isinstance(props, str):
        bad = props
    elif not (math.isfinite(a.safety_margin) and a.safety_margin >= 0):  # (-1 and nan ran)
        bad = f"--safety-margin must be a finite number of m, not negative, got {a.safety_margin}"
    elif a.workers < 1:  # (0 ran as 1)
        bad = f"--workers must be at least 1, got {a.workers}"
    else:
        settings = TwinSettings(a.behaviour, a.safety_margin, acceleration_limit=not a.no_acceleration_limit,
                                properties=props, blind_walkers_see_robot=a.walkers_see_robot)
        bad = _refusal(a.scenarios, settings)  # every file and the behaviour checked before any run
    if bad:
        print(f"{p.prog}: error: {bad}", file=sys.stderr)
        return 2
    jobs = [(path, settings) for path in a.scenarios]
    if a.workers > 1:
        from concurrent.futures import ProcessPoolExecutor
        with ProcessPoolExecutor(a.workers) as pool:
            outcomes = list(pool.map(_run_one, jobs, chunksize=4))
    else:
        outcomes = [_run_one(j) for j in jobs]
    n = len(outcomes)
    counts = {o: sum(x.outcome == o for x in outcomes) for o in ("reached_goal", "collided", "timed_out")}
    for o, k in counts.items():
        lo, hi = clopper_pearson(k, n)
        print(f"{o}: {k}/{n} ({100 * k / n:.1f} %, 95 % CP {100 * lo:.1f}-{100 * hi:.1f} %)")
    collided = [x.name for x in outcomes if x.outcome == "collided"]
    print("collided:", " ".join(collided))
    if a.out:
        a.out.parent.mkdir(parents=True, exist_ok=True)
        a.out.write_text(json.dumps({"settings": asdict(settings), "counts": counts,
                                     "episodes": [asdict(x) for x in outcomes]}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
