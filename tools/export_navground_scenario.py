"""Export navground's own scenes, ``Antipodal`` and ``Corridor``, to gpcnav scenario files
(TOML), so that the peers are also compared on scenes that are not ours.

``--scene antipodal`` (the default): navground's ``Antipodal`` (``navground.sim``) places N
agents at regular intervals on a circle (with ``position_noise``) facing its centre, each
tasked to reach the opposite point: they all meet in the middle. Each episode (navground
seed ``seed + i``) becomes one file:

- agent 0 becomes the robot (our robot, 0.35 m, its wheels and limits): it starts where the
  agent starts, facing where it faces, and its reference is the straight line to the
  agent's goal at the agent's optimal speed;
- the others become walkers (``behaviour = "orca"`` by default, navground's own ORCA, the
  behaviour of navground's scenario; or ``social_force``) with the agent's position, goal,
  radius and optimal speed as preferred speed. In navground's scenario every agent sees
  every other, so the walkers see the robot (``sees_robot = true``) unless ``--blind-walkers``;
- the time limit is ``--time-factor`` (3, as the crowd suites) times the reference's duration;
  sensing noise 0.02 m, seeded by the episode's seed.

``--scene corridor``: navground's ``Corridor``: two walls ``--width`` apart along x (at
y = 0 and y = width), agents placed uniformly inside and spaced apart by navground (0.1 m,
from each other and from the walls), the even ones walking +x and the odd ones -x for ever
(bidirectional), in a corridor of ``--length`` whose ends navground wraps together (a
lattice: who leaves at one end comes in at the other, and is seen across the seam). Our
simulator has no lattice, so the export unwraps it: the periodic corridor is the infinite
corridor in which every walker repeats every ``length``, and the file holds the walkers'
images in the tiles -1, 0, 1 and 2 (the robot drives one length, tile 0 to 1; in the time
limit the people coming towards it come from as far as tile 2). Agent 0 (radius 0.35, our
robot's) becomes the robot: its start, heading +x, its reference the straight line of one
corridor length along +x at its optimal speed. Each walker image walks in its direction at
its optimal speed (its goal that far ahead that it does not arrive within the time limit),
and the walls run on 2 m past where anyone starts or heads. navground's ``Cross`` is not
exported: it has no walls, and its agents go back and forth between four points for ever,
which has no goal to reach.

Usage::

    python tools/export_navground_scenario.py --out out/antipodal --count 200 --seed 1
    python tools/export_navground_scenario.py --scene corridor --out out/corridor --count 200 --seed 1 --blind-walkers
    gpcnav compare out/antipodal/*.toml --controllers gpc,nn,orca,hrvo,social_force,mppi --out out/antipodal.json
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from scenarios.writer import to_toml  # noqa: E402

__all__ = ["antipodal_world", "antipodal_table", "export", "corridor_world", "corridor_table", "export_corridor",
           "CORRIDOR_TILES"]

CORRIDOR_TILES = (-1, 0, 1, 2)
"""The tiles of navground's periodic corridor whose walkers a file holds (tile 0: navground's own)."""


def antipodal_world(agents: int, radius_m: float, agent_radius_m: float, speed_mps: float, position_noise_m: float,
                    seed: int):
    """navground's ``Antipodal`` world for ``seed`` (its agents: ORCA, ``Omni`` kinematics;
    only their places, goals, radii and speeds are exported)."""
    import navground.sim as sim
    yaml = f"""
type: Antipodal
radius: {radius_m!r}
position_noise: {position_noise_m!r}
groups:
  - number: {int(agents)}
    radius: {agent_radius_m!r}
    kinematics:
      type: Omni
      max_speed: {speed_mps!r}
    behavior:
      type: ORCA
      optimal_speed: {speed_mps!r}
"""
    world = sim.World()
    sim.load_scenario(yaml).init_world(world, seed=int(seed))
    return world


def _r(v) -> float:
    """navground's float32 values, to the micrometre (the files stay readable)."""
    return round(float(v), 6)


def antipodal_table(world, name: str, seed: int, behaviour: str = "orca", sees_robot: bool = True,
                    time_factor: float = 3.0) -> dict:
    """The scenario (as the TOML's tables) of a navground world: agent 0 the robot, the
    others walkers."""
    robot, *others = world.agents
    start = [_r(v) for v in robot.position]
    goal = [_r(v) for v in robot.task.waypoints[0]]
    length = _r(math.hypot(goal[0] - start[0], goal[1] - start[1]))
    speed = _r(robot.behavior.optimal_speed)
    table = {
        "name": name,
        "description": f"navground's Antipodal scenario, seed {seed}: {len(world.agents)} agents, agent 0 the robot",
        "duration_s": round(time_factor * length / speed, 3),
        "robot": {"position": start, "heading_deg": _r(math.degrees(float(robot.orientation)))},
        "reference": {"position": start,
                      "heading_deg": _r(math.degrees(math.atan2(goal[1] - start[1], goal[0] - start[0]))),
                      "speed_mps": speed, "segments": [{"line_m": length}]},
        "moving_obstacles": [],
        "sensing": {"position_noise_std_m": 0.02, "seed": int(seed)},
    }
    for agent in others:
        table["moving_obstacles"].append({
            "position": [_r(v) for v in agent.position], "radius_m": _r(agent.radius), "behaviour": behaviour,
            "goal": [_r(v) for v in agent.task.waypoints[0]],
            "preferred_speed_mps": _r(agent.behavior.optimal_speed), "sees_robot": bool(sees_robot)})
    return table


ROBOT_RADIUS_M = 0.35
"""The robot's radius in the files (the contract's robot; the files carry no [robot] override)."""


def robot_overlaps(table: dict, robot_radius_m: float) -> bool:
    """Whether the robot of a scenario ``table`` starts overlapping one of its walkers (a file
    gpcnav refuses)."""
    rx, ry = table["robot"]["position"]
    return any(math.hypot(m["position"][0] - rx, m["position"][1] - ry) <= robot_radius_m + m["radius_m"]
               for m in table["moving_obstacles"])


def export(out: Path, count: int, seed: int, agents: int = 7, radius_m: float = 4.0, agent_radius_m: float = 0.3,
           speed_mps: float = 0.4, position_noise_m: float = 0.1, behaviour: str = "orca", sees_robot: bool = True,
           time_factor: float = 3.0, skipped: list | None = None) -> list[Path]:
    """Write ``count`` scenario files (navground seeds ``seed`` .. ``seed + count - 1``). A
    seed whose robot (0.35 m, larger than navground's agent 0) starts overlapping a walker is
    left out, and appended to ``skipped``: a scenario file refuses it (before 2026-11-30 it was
    written, and gpcnav refused it; ``--agents 20 --radius 1``)."""
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(count):
        s = seed + i
        world = antipodal_world(agents, radius_m, agent_radius_m, speed_mps, position_noise_m, s)
        name = f"navground-antipodal-{agents}-{s:05d}"
        table = antipodal_table(world, name, s, behaviour, sees_robot, time_factor)
        if robot_overlaps(table, ROBOT_RADIUS_M):
            if skipped is not None:
                skipped.append(s)
            continue
        path = out / f"{name}.toml"
        path.write_text(to_toml(table), encoding="utf-8")
        paths.append(path)
    return paths


def corridor_world(agents: int, length_m: float, width_m: float, agent_radius_m: float, robot_radius_m: float,
                   speed_mps: float, seed: int):
    """navground's ``Corridor`` world for ``seed``: agent 0 with the robot's radius, the
    others the walkers' (ORCA, ``Omni`` kinematics; only their places, directions, radii and
    speeds are exported)."""
    import navground.sim as sim
    group = """
  - number: {n}
    radius: {r!r}
    kinematics:
      type: Omni
      max_speed: {v!r}
    behavior:
      type: ORCA
      optimal_speed: {v!r}"""
    yaml = (f"type: Corridor\nlength: {length_m!r}\nwidth: {width_m!r}\nbidirectional: true\ngroups:"
            + group.format(n=1, r=robot_radius_m, v=speed_mps)
            + group.format(n=int(agents) - 1, r=agent_radius_m, v=speed_mps) + "\n")
    world = sim.World()
    sim.load_scenario(yaml).init_world(world, seed=int(seed))
    return world


def corridor_table(world, name: str, seed: int, length_m: float, behaviour: str = "orca", sees_robot: bool = True,
                   time_factor: float = 3.0) -> dict:
    """The scenario (as the TOML's tables) of navground's corridor ``world`` unwrapped (see
    the module's docstring): agent 0 the robot, the other agents' images in
    :data:`CORRIDOR_TILES` walkers, the two walls."""
    robot, *others = world.agents
    start = [_r(v) for v in robot.position]
    direction = [_r(v) for v in robot.task.direction]
    if direction != [1.0, 0.0]:
        raise ValueError(f"navground's corridor agent 0 heads {direction}, not +x")
    speed = _r(robot.behavior.optimal_speed)
    duration = round(time_factor * length_m / speed, 3)
    ys = sorted({_r(w.line.p1[1]) for w in world.walls} | {_r(w.line.p2[1]) for w in world.walls})
    table = {
        "name": name,
        "description": (f"navground's Corridor scenario, seed {seed}: {len(world.agents)} agents in {length_m:g} m, "
                        f"the lattice unwrapped (tiles {', '.join(map(str, CORRIDOR_TILES))}), agent 0 the robot"),
        "duration_s": duration,
        "robot": {"position": start, "heading_deg": 0.0},
        "reference": {"position": start, "heading_deg": 0.0, "speed_mps": speed,
                      "segments": [{"line_m": _r(length_m)}]},
        "moving_obstacles": [],
        "walls": [],
        "sensing": {"position_noise_std_m": 0.02, "seed": int(seed)},
    }
    xs = [start[0], start[0] + length_m]
    for tile in CORRIDOR_TILES:
        for agent in others:
            x, y = (_r(v) for v in agent.position)
            x = _r(x + tile * length_m)
            dx = _r(float(agent.task.direction[0]))
            v = _r(agent.behavior.optimal_speed)
            goal_x = _r(x + dx * (v * duration + 1.0))  # not reached within the time limit
            xs += [x, goal_x]
            table["moving_obstacles"].append({
                "position": [x, y], "radius_m": _r(agent.radius), "behaviour": behaviour, "goal": [goal_x, y],
                "preferred_speed_mps": v, "sees_robot": bool(sees_robot)})
    lo, hi = _r(min(xs) - 2.0), _r(max(xs) + 2.0)
    table["walls"] = [{"points": [[lo, y], [hi, y]]} for y in ys]
    return table


def export_corridor(out: Path, count: int, seed: int, agents: int = 6, length_m: float = 10.0, width_m: float = 2.5,
                    agent_radius_m: float = 0.3, robot_radius_m: float = 0.35, speed_mps: float = 0.4,
                    behaviour: str = "orca", sees_robot: bool = True, time_factor: float = 3.0) -> list[Path]:
    """Write the corridor scenario files of navground seeds ``seed`` .. ``seed + count - 1``;
    returns the files written and the seeds not written: navground spaces its agents apart
    but not always across the lattice's seam (seed 34 of the defaults starts agent 0 0.14 m
    into another's image), and a scenario file refuses a robot that starts overlapping a
    walker; such a seed is left out and named, not repaired. A corridor no wider than the
    robot's disc is refused (ValueError) before any file is written: every file's robot would
    start touching a wall, which a scenario file refuses (they were all written, and none loaded)."""
    if not width_m > 2 * robot_radius_m:
        raise ValueError(f"--width {width_m:g} m: the corridor must be wider than the robot's disc "
                         f"({2 * robot_radius_m:g} m across); each file's robot would start touching a wall")
    out.mkdir(parents=True, exist_ok=True)
    paths, skipped = [], []
    for i in range(count):
        s = seed + i
        world = corridor_world(agents, length_m, width_m, agent_radius_m, robot_radius_m, speed_mps, s)
        name = f"navground-corridor-{agents}-{s:05d}"
        table = corridor_table(world, name, s, length_m, behaviour, sees_robot, time_factor)
        if robot_overlaps(table, float(world.agents[0].radius)):
            skipped.append(s)
            continue
        path = out / f"{name}.toml"
        path.write_text(to_toml(table), encoding="utf-8")
        paths.append(path)
    return paths, skipped


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scene", choices=("antipodal", "corridor"), default="antipodal", help="navground's scene")
    p.add_argument("--out", type=Path, required=True, help="folder for the scenario files")
    p.add_argument("--count", type=int, default=200, help="episodes (navground seeds seed .. seed + count - 1)")
    p.add_argument("--seed", type=int, default=1, help="first navground seed")
    p.add_argument("--agents", type=int, default=None,
                   help="agents, the robot included (default 7 on the circle; 6 in the corridor: 5 people per 10 m, as our suites)")
    p.add_argument("--radius", type=float, default=4.0, help="antipodal: circle radius, m (default 4, as circle-crossing)")
    p.add_argument("--length", type=float, default=10.0, help="corridor: length, m (default 10, navground's)")
    p.add_argument("--width", type=float, default=2.5,
                   help="corridor: width, m (default 2.5, our corridor suite's; navground's 1 m is too narrow for "
                        "our 0.35 m robot to pass a 0.3 m person)")
    p.add_argument("--agent-radius", type=float, default=0.3, help="walkers' radius, m (default 0.3)")
    p.add_argument("--speed", type=float, default=0.4, help="everyone's optimal speed, m/s (default 0.4)")
    p.add_argument("--position-noise", type=float, default=0.1,
                   help="antipodal: navground's position_noise, m (default 0.1)")
    p.add_argument("--behaviour", choices=("orca", "social_force"), default="orca", help="the walkers' behaviour")
    p.add_argument("--blind-walkers", action="store_true", help="walkers do not see the robot (sees_robot = false)")
    p.add_argument("--time-factor", type=float, default=3.0, help="time limit / reference duration (default 3)")
    a = p.parse_args(argv)
    agents = a.agents if a.agents is not None else (7 if a.scene == "antipodal" else 6)
    if a.count < 1 or agents < 2 or a.seed < 0:
        p.error("--count must be at least 1, --agents at least 2, --seed at least 0")
    if not all(math.isfinite(v) and v > 0 for v in (a.length, a.width, a.radius, a.agent_radius, a.speed,
                                                     a.time_factor)):
        p.error("--length, --width, --radius, --agent-radius, --speed and --time-factor must be finite and positive")
    if a.out.exists() and not a.out.is_dir():  # (FileExistsError's traceback)
        p.error(f"--out {a.out} exists and is not a folder")
    if a.scene == "corridor":
        try:  # (a corridor no wider than the robot is refused before any file is written)
            paths, skipped = export_corridor(a.out, a.count, a.seed, agents, a.length, a.width, a.agent_radius,
                                             ROBOT_RADIUS_M, a.speed, a.behaviour, not a.blind_walkers, a.time_factor)
        except ValueError as exc:
            p.error(str(exc))
    else:
        skipped = []
        paths = export(a.out, a.count, a.seed, agents, a.radius, a.agent_radius, a.speed, a.position_noise,
                       a.behaviour, not a.blind_walkers, a.time_factor, skipped)
    if skipped:
        print(f"{len(skipped)} seeds not written, navground's start has agent 0 (the robot) overlapping a walker: "
              f"{', '.join(map(str, skipped))}", file=sys.stderr)
    print(f"{len(paths)} scenario files in {a.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
