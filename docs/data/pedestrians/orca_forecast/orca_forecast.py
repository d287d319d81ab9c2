"""Prototype: the GPC with an interaction-aware forecast (each tracked person rolled forward
with navground's ORCA among the others, from the filter's estimate, heading on at its
estimated velocity), to see whether such a forecast would help at all. A study, not shipped (docs/pedestrians.md,
"Among 30 walkers"). Each walker of the forecast heads for a point 100 m along its estimated
velocity at its estimated speed, steps of 0.1 s, the walls as navground's line obstacles;
``--mode social-sees`` puts the robot among them at its current velocity; ``--mode plain`` is
the shipped GPC on the same episodes. About 0.2 s a decision (navground's Python binding, one
call per walker and step): a prototype's cost, not a planner's.

    python orca_forecast.py --suite square-crossing --movers 30 --seed 3 --behaviour orca \
        --episodes 0-39 --mode social --out social-a.json
"""
import sys, math, argparse, json
from dataclasses import replace
import numpy as np
sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[4]))
from navground import core
from casadi_gpc.config import preset
from casadi_gpc.planner.gpc import GPCController
from casadi_gpc.safety import Shield
from casadi_gpc.types import ObstacleForecast
from gpcnav.commands.common import for_run
from gpcnav.controllers import check_settings
from scenarios import Suite
from scenarios.simulator import simulate

DT = 0.1

def orca_rollout(p, v, radii, H, T, lines, robot=None, step=DT):
    """p, v (N,2) -> (N,H,2) positions at (k+1)T."""
    N = len(p)
    bs = []
    for i in range(N):
        b = core.Behavior.make_type("ORCA")
        b.kinematics = core.Kinematics.make_type("Omni")
        s = float(np.hypot(*v[i]))
        top = max(s, 0.05)
        b.kinematics.max_speed = b.max_speed = b.optimal_speed = top
        b.radius = float(radii[i]); b.safety_margin = 0.05
        goal = p[i] + (v[i] / s * 100.0 if s > 0.05 else np.zeros(2))
        b.target = core.Target.Point(np.asarray(goal, float), 0.05)
        b.environment_state.line_obstacles = lines
        bs.append((b, s > 0.05))
    pos, vel = p.copy(), v.copy()
    out = np.empty((N, H, 2))
    n_sub = int(round(T / step))
    for k in range(H):
        for _ in range(n_sub):
            new = vel.copy()
            for i, (b, moving) in enumerate(bs):
                if not moving:
                    new[i] = 0.0; continue
                nb = [core.Neighbor(pos[o], float(radii[o]), vel[o], o) for o in range(N) if o != i and np.hypot(*(pos[o]-pos[i])) < 5.0]
                if robot is not None:
                    nb.append(core.Neighbor(robot[0], robot[2], robot[1], -1))
                b.position = pos[i]; b.velocity = vel[i]
                b.environment_state.neighbors = nb
                new[i] = np.asarray(b.compute_cmd(step, core.Frame.absolute).velocity, float)
            vel = new
            pos = pos + vel * step
        out[:, k] = pos
    return out


class SocialGPC(GPCController):
    sees_robot = False
    def estimate(self, obs):
        own = super().estimate(obs)
        if len(own) < 2:
            return own
        H, T = self.config.horizon, self.config.sample_time_s
        m = np.array([np.asarray(f.means_m) for f in own])  # (N,H,2)
        v = (m[:, 1] - m[:, 0]) / T
        p = m[:, 0] - v * T
        radii = np.array([f.radius_m for f in own])
        lines = [core.LineSegment(np.asarray(a, float), np.asarray(b, float)) for w in (obs.walls or ()) for a, b in zip(w.points[:-1], w.points[1:])] if obs.walls else []
        robot = None
        if self.sees_robot:
            r = obs.robot
            sp = 0.5 * (r.v_right_mps + r.v_left_mps)
            robot = (np.array([r.x_m, r.y_m]), np.array([sp * math.cos(r.heading_rad), sp * math.sin(r.heading_rad)]), self.robot.radius_m)
        means = orca_rollout(p, v, radii, H, T, lines, robot)
        return [ObstacleForecast(f.obstacle_id, f.radius_m, means[i], np.asarray(f.covs_m2)) for i, f in enumerate(own)]


ap = argparse.ArgumentParser()
ap.add_argument("--suite"); ap.add_argument("--movers", type=int, default=5); ap.add_argument("--seed", type=int)
ap.add_argument("--behaviour", default=None); ap.add_argument("--episodes"); ap.add_argument("--mode", default="social")
ap.add_argument("--out")
a = ap.parse_args()
lo, hi = (int(x) for x in a.episodes.split("-"))
suite = Suite(a.suite, hi + 1, a.seed, a.movers, a.behaviour)
res = []
for i in range(lo, hi + 1):
    sc = suite.scenario(i)
    cfg = for_run(preset("improved"), [sc])
    cls = SocialGPC if a.mode.startswith("social") else GPCController
    gpc = cls(cfg, sc.robot)
    if a.mode == "social-sees":
        gpc.sees_robot = True
    log = simulate(sc, Shield(gpc, sc.robot, check_settings("gpc", gpc, cfg, "on"), planner_config=cfg), "gpc")
    ct = np.array(log.compute_time_s)
    res.append({"i": i, "outcome": log.outcome, "min_clear": float(log.min_clearance_m), "median_ms": float(np.median(ct)*1e3)})
    print(i, log.outcome, round(float(log.min_clearance_m), 3), round(float(np.median(ct)*1e3), 2), flush=True)
outs = [r["outcome"] for r in res]
print(a.mode, {o: outs.count(o) for o in set(outs)})
if a.out: json.dump(res, open(a.out, "w"))
