"""Export navground's own ``Antipodal`` scenario to gpcnav scenario files (TOML), so that the
peers are also compared on a scene that is not ours.

navground's ``Antipodal`` (``navground.sim``) places N agents at regular intervals on a
circle (with ``position_noise``) facing its centre, each tasked to reach the opposite point:
they all meet in the middle. Each episode (navground seed ``seed + i``) becomes one file:

- agent 0 becomes the robot (our robot, 0.35 m, its wheels and limits): it starts where the
  agent starts, facing where it faces, and its reference is the straight line to the
  agent's goal at the agent's optimal speed;
- the others become walkers (``behaviour = "orca"`` by default, navground's own ORCA, the
  behaviour of navground's scenario; or ``social_force``) with the agent's position, goal,
  radius and optimal speed as preferred speed. In navground's scenario every agent sees
  every other, so the walkers see the robot (``sees_robot = true``) unless ``--blind-walkers``;
- the time limit is ``--time-factor`` (3, as the crowd suites) times the reference's duration;
  sensing noise 0.02 m, seeded by the episode's seed.

Usage::

    python tools/export_navground_scenario.py --out out/antipodal --count 200 --seed 1
    gpcnav compare out/antipodal/*.toml --controllers gpc,nn,orca,hrvo,social_force,mppi --out out/antipodal.json
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from scenarios.writer import to_toml  # noqa: E402

__all__ = ["antipodal_world", "antipodal_table", "export"]


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


def export(out: Path, count: int, seed: int, agents: int = 7, radius_m: float = 4.0, agent_radius_m: float = 0.3,
           speed_mps: float = 0.4, position_noise_m: float = 0.1, behaviour: str = "orca", sees_robot: bool = True,
           time_factor: float = 3.0) -> list[Path]:
    """Write ``count`` scenario files (navground seeds ``seed`` .. ``seed + count - 1``)."""
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(count):
        s = seed + i
        world = antipodal_world(agents, radius_m, agent_radius_m, speed_mps, position_noise_m, s)
        name = f"navground-antipodal-{agents}-{s:05d}"
        path = out / f"{name}.toml"
        path.write_text(to_toml(antipodal_table(world, name, s, behaviour, sees_robot, time_factor)), encoding="utf-8")
        paths.append(path)
    return paths


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", type=Path, required=True, help="folder for the scenario files")
    p.add_argument("--count", type=int, default=200, help="episodes (navground seeds seed .. seed + count - 1)")
    p.add_argument("--seed", type=int, default=1, help="first navground seed")
    p.add_argument("--agents", type=int, default=7, help="agents on the circle, the robot included (default 7)")
    p.add_argument("--radius", type=float, default=4.0, help="circle radius, m (default 4, as circle-crossing)")
    p.add_argument("--agent-radius", type=float, default=0.3, help="walkers' radius, m (default 0.3)")
    p.add_argument("--speed", type=float, default=0.4, help="everyone's optimal speed, m/s (default 0.4)")
    p.add_argument("--position-noise", type=float, default=0.1, help="navground's position_noise, m (default 0.1)")
    p.add_argument("--behaviour", choices=("orca", "social_force"), default="orca", help="the walkers' behaviour")
    p.add_argument("--blind-walkers", action="store_true", help="walkers do not see the robot (sees_robot = false)")
    p.add_argument("--time-factor", type=float, default=3.0, help="time limit / reference duration (default 3)")
    a = p.parse_args(argv)
    if a.count < 1 or a.agents < 2 or a.seed < 0:
        p.error("--count must be at least 1, --agents at least 2, --seed at least 0")
    paths = export(a.out, a.count, a.seed, a.agents, a.radius, a.agent_radius, a.speed, a.position_noise, a.behaviour,
                   not a.blind_walkers, a.time_factor)
    print(f"{len(paths)} scenario files in {a.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
