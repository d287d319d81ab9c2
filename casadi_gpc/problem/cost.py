"""The GPC problem written once in CasADi: rollout, the paper's cost and the limits.

Decision variables: the wheel-speed increments ``u = [dVr_0, dVl_0, ..., dVr_{H-1},
dVl_{H-1}]`` (m/s). Everything that changes from tick to tick is a parameter, packed by
:class:`ParameterLayout`, so the NLP is built once and solved many times.

Cost (``docs/model.md``)::

    J = sum_i  wt w_i ((x_i - xd_i)^2 + (y_i - yd_i)^2) + wh wrap(th_i - thd_i)^2
      + sum_i  lambda1 (dVr_i^2 + dVl_i^2) + lambda2 (Vr_i - Vl_i)^2
      + sum_j sum_i  xi / (P_ij dist_ij^2)          (paper; or xi/P (1/d - 1/d0)_+^2)
      [+ sum_j sum_i  w (margin_ij - dist_ij)_+^2]   (improved: soft clearance constraint,
                                                       ( )_+ smoothed, PlannerConfig.margin_smoothing_m)
      [+ sum_j sum_s  w (margin_jH - dist_js)_+^2]   (an option in neither preset: the robot
                                                       standing at its last position, each mover
                                                       carried on straight s seconds beyond the
                                                       horizon, PlannerConfig.beyond_horizon_s)

with ``dist`` the clearance between the robot's disc and the obstacle's disc and ``w_i`` the
goal factor of desired pose i (``PlannerConfig.goal_weight`` at the end of the path, else 1).
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import casadi as ca
import numpy as np

from ..config import PlannerConfig
from ..estimation.obstacle_model import worst_std_m
from ..robot import RobotParams, robot_step
from ..types import ObstacleForecast, StaticObstacle

__all__ = ["ParameterLayout", "GPCProblem", "build_problem", "parameter_blocks", "effort_cost", "state_cost", "rollout_states",
           "FAR_AWAY_M", "beyond_horizon_cost", "margin_terms", "layout_of", "FRAME_TILE_M", "frame_origin",
           "to_world"]

FAR_AWAY_M = 1.0e4  # where unused obstacle slots are parked

FRAME_TILE_M = 1000.0
"""The NLP is posed in a frame whose origin is the robot's position rounded to this: within
500 m of the map's origin (every suite and recording here) the map's own frame, bit for bit.
Far from it (a map in UTM coordinates, 5e6 m) the positions the NLP reads stay within a
kilometre: there the SQP failed starts and its decisions took three times as long, and at
1e8 m twenty times (p95 10 times; the same plan)."""


def frame_origin(x0) -> np.ndarray:
    """The origin of the NLP's frame for a robot at ``x0`` (x, y, ...): its position rounded to
    :data:`FRAME_TILE_M` (zero near the map's origin). :meth:`ParameterLayout.pack` subtracts
    it from every position it packs; :func:`to_world` adds it back to the poses the NLP's
    functions give."""
    return np.round(np.asarray(x0[:2], dtype=float) / FRAME_TILE_M) * FRAME_TILE_M


def to_world(poses, x0) -> np.ndarray:
    """``poses`` (rows x, y, heading) of the NLP's frame for a robot at ``x0``, in the map's
    frame (the same array where the frames are one)."""
    o = frame_origin(x0)
    if not o.any():
        return poses
    out = np.array(poses, dtype=float)
    out[:, :2] += o
    return out


@dataclass(frozen=True)
class ParameterLayout:
    """Offsets of the named blocks in the NLP parameter vector."""

    horizon: int
    max_moving: int
    max_static: int
    max_walls: int = 0
    margin: tuple[float, float] | None = None
    """The clearance margin and its sigmas when the NLP takes them as parameters (block
    ``margin``: :attr:`casadi_gpc.config.PlannerConfig.walls_margin_m`), the values an
    unset :meth:`pack` writes; None: constants of the cost."""
    directional: bool = False
    """Whether the NLP can inflate its margin by each mover's deviation along the line from
    it to the robot (blocks ``mov_cov``, the forecasts' covariances, and ``dir``, 1 at the
    ticks that do, 0 where the worst deviation ``mov_sigma`` is used:
    :attr:`casadi_gpc.config.PlannerConfig.walls_directional_sigma`)."""
    robot_radius_m: float = RobotParams.radius_m
    """The robot's radius an unset :meth:`pack` writes (block ``robot_r``, the parameters' last):
    the NLP takes it as a parameter, so one compiled NLP serves robots of every size (a constant
    of the cost made a new NLP, 100-115 s of compiling a solver, for each size a user tried)."""

    @property
    def blocks(self) -> dict[str, tuple[int, ...]]:
        H, M, S, W = self.horizon, self.max_moving, self.max_static, self.max_walls
        extra = {"wall_ab": (W, 4), "wall_on": (W,)} if W else {}  # segment ends (ax, ay, bx, by)
        if self.margin is not None:
            extra["margin"] = (2,)  # the clearance margin (m) and the sigmas that inflate it
        if self.directional:
            extra["mov_cov"] = (M, H, 3)  # the forecasts' covariances: xx, xy, yy (m^2)
            extra["dir"] = (1,)  # 1: the margin's deviation along the line to the robot; 0: the worst
        return {
            "x0": (5,),                  # x, y, heading, v_right, v_left
            "ref": (H, 3),               # desired x, y, heading at steps 1..H
            "ref_w": (H,),               # tracking weight factor of each (goal_weight at the path's end)
            "mov_xy": (M, H, 2),         # predicted obstacle positions
            "mov_p": (M, H),             # the paper's P (>= 1)
            "mov_sigma": (M, H),         # predicted position std (m) for the margin
            "mov_r": (M,),
            "mov_on": (M,),
            "sta_xy": (S, 2),
            "sta_r": (S,),
            "sta_on": (S,),
            **extra,
            "robot_r": (1,),             # the robot's radius (m)
        }

    @cached_property
    def size(self) -> int:
        return sum(int(np.prod(s)) for s in self.blocks.values())

    def slices(self) -> dict[str, slice]:
        """The named blocks' places in the parameter vector (the same dict every call: do not
        change it)."""
        return self._slices

    @cached_property
    def _slices(self) -> dict[str, slice]:
        out, k = {}, 0
        for name, shape in self.blocks.items():
            n = int(np.prod(shape))
            out[name] = slice(k, k + n)
            k += n
        return out

    def pack(
        self,
        x0: np.ndarray,
        ref: np.ndarray,
        forecasts: list[ObstacleForecast] | tuple = (),
        statics: list[StaticObstacle] | tuple = (),
        uncertainty_scale_m: float = 0.5,
        ref_weights: np.ndarray | None = None,
        walls=(),
        margin: tuple[float, float] | None = None,
        sigma_cap_m: float | None = None,
        directional: bool = False,
    ) -> np.ndarray:
        """Parameter vector for one tick, the obstacles in the order given
        (:mod:`casadi_gpc.problem.selection` chooses them). ``ref_weights``: the tracking weight
        factor of each desired pose (:func:`casadi_gpc.problem.selection.goal_weights`; None: 1).
        ``margin``: the clearance margin and its sigmas for this tick, for a layout that takes
        them (None: the layout's own, :attr:`margin`). ``sigma_cap_m``: the movers' standard
        deviations that inflate the margin taken at most this (None: their own).
        ``directional``: this tick's margin takes each mover's deviation along the line from it
        to the robot (a layout with :attr:`directional`; else its worst, ``mov_sigma``).
        Positions are given in the map's frame and packed in the NLP's, whose origin is
        :func:`frame_origin` of ``x0`` (the map's own near its origin)."""
        H, M, S = self.horizon, self.max_moving, self.max_static
        if len(forecasts) > M or len(statics) > S:
            raise ValueError(f"at most {M} moving and {S} static obstacles fit this NLP")
        p = self._empty.copy()  # every slot parked far away and off (numpy's per-call cost is what counts here)
        sl = self._slices
        o = frame_origin(x0)
        far = bool(o.any())  # positions in the frame of frame_origin (near the map's origin, as they are)
        if far:
            x0 = np.array(x0, dtype=float)
            x0[:2] -= o
            ref = np.array(ref, dtype=float)
            ref[:, :2] -= o
        p[sl["x0"]] = x0
        p[sl["ref"]] = np.asarray(ref, dtype=float).reshape(-1)
        p[sl["ref_w"]] = 1.0 if ref_weights is None else np.asarray(ref_weights, dtype=float)
        n = len(forecasts)
        if n:  # all forecasts at once, written into the slots' views of p
            covs = np.array([f.covs_m2 for f in forecasts], dtype=float)      # (n, H, 2, 2)
            p[sl["mov_xy"]].reshape(M, H, 2)[:n] = [f.means_m for f in forecasts]
            if far:
                p[sl["mov_xy"]].reshape(M, H, 2)[:n] -= o
            p[sl["mov_p"]].reshape(M, H)[:n] = 1.0 + (covs[..., 0, 0] + covs[..., 1, 1]) / uncertainty_scale_m ** 2
            sigma = worst_std_m(covs)
            p[sl["mov_sigma"]].reshape(M, H)[:n] = sigma if sigma_cap_m is None else np.minimum(sigma, sigma_cap_m)
            p[sl["mov_r"]][:n] = [f.radius_m for f in forecasts]
            p[sl["mov_on"]][:n] = 1.0
            if directional:
                p[sl["mov_cov"]].reshape(M, H, 3)[:n] = np.stack([covs[..., 0, 0], covs[..., 0, 1], covs[..., 1, 1]], -1)
        if directional:
            if not self.directional:
                raise ValueError("this NLP takes no directional deviations")
            p[sl["dir"]] = 1.0
        if statics:
            sta_xy, sta_r, sta_on = p[sl["sta_xy"]], p[sl["sta_r"]], p[sl["sta_on"]]
            for j, st in enumerate(statics):
                sta_xy[2 * j:2 * j + 2] = np.asarray(st.position_m, dtype=float) - o if far else st.position_m
                sta_r[j] = st.radius_m
                sta_on[j] = 1.0
        if len(walls):
            if len(walls) > self.max_walls:
                raise ValueError(f"at most {self.max_walls} wall segments fit this NLP")
            ab = np.asarray(walls, dtype=float).reshape(-1, 2)
            p[sl["wall_ab"]][:4 * len(walls)] = (ab - o if far else ab).reshape(-1)
            p[sl["wall_on"]][:len(walls)] = 1.0
        if margin is not None:
            if self.margin is None:
                raise ValueError("this NLP takes no margin parameters")
            p[sl["margin"]] = margin
        return p

    @cached_property
    def _empty(self) -> np.ndarray:
        """The parameters of no obstacle: moving and static slots parked at
        :data:`FAR_AWAY_M`, off, radius 0, the paper's P 1 and no uncertainty."""
        p = np.zeros(self.size)
        sl = self._slices
        for name in ("mov_xy", "sta_xy"):
            p[sl[name]] = FAR_AWAY_M
        p[sl["mov_p"]] = 1.0
        if self.max_walls:  # a segment of 1 m, far away
            p[sl["wall_ab"]] = np.tile([FAR_AWAY_M, FAR_AWAY_M, FAR_AWAY_M + 1.0, FAR_AWAY_M], self.max_walls)
        if self.margin is not None:
            p[sl["margin"]] = self.margin
        p[sl["robot_r"]] = self.robot_radius_m
        return p

    def unpack(self, p: np.ndarray) -> dict[str, np.ndarray]:
        return {name: np.asarray(p[s]).reshape(self.blocks[name]) for name, s in self.slices().items()}


@dataclass(frozen=True)
class GPCProblem:
    """The symbolic problem and the CasADi functions built from it (built once)."""

    config: PlannerConfig
    robot: RobotParams
    layout: ParameterLayout
    nlp: dict
    """``{'x', 'p', 'f', 'g'}`` for ``nlpsol``."""
    cost_fn: ca.Function
    """``J(u, p)``."""
    terms_fn: ca.Function
    """``(tracking, effort, turning, obstacles, margin)(u, p)``: the cost by term."""
    rollout_fn: ca.Function
    """``(poses (H x 3), wheels (H x 2))(u, p)``."""
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray

    @property
    def n_u(self) -> int:
        return 2 * self.config.horizon

    @property
    def code_key(self) -> tuple:
        """What the NLP's generated code depends on besides a solver's own options
        (:func:`~casadi_gpc.solvers.compiling.known_library`): the settings and the robot but its
        radius, a parameter (robots of every size share the code)."""
        r = self.robot
        return self.config, r.wheel_base_m, r.max_wheel_speed_mps, r.max_wheel_accel_mps2


def _smooth_positive(d, eps):
    return 0.5 * (d + ca.sqrt(d * d + eps * eps))


def parameter_blocks(layout: ParameterLayout, p) -> dict:
    """The named blocks of the symbolic parameter vector ``p`` (``ref`` as an (H, 3) matrix)."""
    P = {name: p[s] for name, s in layout.slices().items()}
    P["ref"] = ca.reshape(P["ref"], 3, layout.horizon).T  # row-major (H, 3) as packed
    return P


def effort_cost(config: PlannerConfig, dvr, dvl):
    """lambda1 (dVr^2 + dVl^2): the cost of one step's increments."""
    return config.lambda1 * (dvr ** 2 + dvl ** 2)


def state_cost(config: PlannerConfig, P: dict, i: int, x, y, th, vr, vl):
    """``(tracking, turning, obstacles, margin)`` of the state after step ``i`` (0-based).

    Together with :func:`effort_cost` this is the whole stage cost; it is used by the
    single-shooting NLP below and by the multiple-shooting form in ``solvers.py``."""
    H, M, S = config.horizon, config.max_moving, config.max_static
    ref = P["ref"]
    obst = margin_pen = 0
    turning = config.lambda2 * (vr - vl) ** 2
    e_h = th - ref[i, 2]
    tracking = config.tracking_weight * P["ref_w"][i] * ((x - ref[i, 0]) ** 2 + (y - ref[i, 1]) ** 2)
    tracking += config.heading_weight * ca.atan2(ca.sin(e_h), ca.cos(e_h)) ** 2
    obstacles = []
    for j in range(M):
        k = (j * H + i) * 2
        obstacles.append((P["mov_xy"][k], P["mov_xy"][k + 1], P["mov_r"][j], P["mov_on"][j],
                          P["mov_p"][j * H + i], _mover_sigma(P, j, H, i, x, y, P["mov_xy"][k], P["mov_xy"][k + 1]),
                          config.xi_moving))
    for j in range(S):
        obstacles.append((P["sta_xy"][2 * j], P["sta_xy"][2 * j + 1], P["sta_r"][j], P["sta_on"][j],
                          1.0, 0.0, config.xi_static))
    for j in range(config.max_walls):  # a wall: a static obstacle of no radius at its point nearest the robot
        ax, ay, bx, by = (P["wall_ab"][4 * j + k] for k in range(4))
        dx, dy = bx - ax, by - ay
        t = ca.fmin(ca.fmax(((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy + 1e-12), 0.0), 1.0)
        obstacles.append((ax + t * dx, ay + t * dy, 0.0, P["wall_on"][j], 1.0, 0.0, config.xi_static))
    if i == H - 1:
        margin_pen += beyond_horizon_cost(config, P, x, y)
    margin_m, sigmas = margin_terms(config, P)
    for ox, oy, r_o, on, p_unc, sigma, xi in obstacles:
        centre = ca.sqrt((x - ox) ** 2 + (y - oy) ** 2 + 1e-12)
        d = centre - P["robot_r"] - r_o
        d_eff = _smooth_positive(d, config.clearance_softening_m)
        if config.influence_m is None:
            obst += on * xi / (p_unc * d_eff ** 2)
        else:
            obst += on * xi / p_unc * ca.fmax(1.0 / d_eff - 1.0 / config.influence_m, 0.0) ** 2
        if config.clearance_margin_m is not None:
            m = margin_m + sigmas * sigma
            e = config.margin_smoothing_m
            violation = ca.fmax(m - d, 0.0) if e is None else _smooth_positive(m - d, e)
            margin_pen += on * config.clearance_penalty * violation ** 2
    return tracking, turning, obst, margin_pen


def _mover_sigma(P: dict, j: int, H: int, i: int, x, y, ox, oy):
    """The deviation that inflates the margin from mover ``j`` at step ``i``: its forecast's
    worst (``mov_sigma``), or, at the ticks whose ``dir`` is 1, its deviation along the line
    from it to the robot at ``(x, y)``, sqrt(u' C u) with u that line's direction: a person's
    forecast is far surer across their way than along it (its speed less known than its
    heading), and a robot beside them needs only the room across."""
    worst = P["mov_sigma"][j * H + i]
    if "dir" not in P:
        return worst
    c = 3 * (j * H + i)
    sxx, sxy, syy = P["mov_cov"][c], P["mov_cov"][c + 1], P["mov_cov"][c + 2]
    dx, dy = x - ox, y - oy
    along = ca.sqrt((dx * dx * sxx + 2 * dx * dy * sxy + dy * dy * syy) / (dx * dx + dy * dy + 1e-12) + 1e-12)
    return ca.if_else(P["dir"][0] > 0.5, along, worst)


def margin_terms(config: PlannerConfig, P: dict) -> tuple:
    """The clearance margin and the sigmas that inflate it: the NLP's parameters where its
    layout takes them (block ``margin``), else the settings' constants."""
    if "margin" in P:
        return P["margin"][0], P["margin"][1]
    return config.clearance_margin_m, config.uncertainty_sigmas


def layout_of(config: PlannerConfig, robot: RobotParams | None = None) -> ParameterLayout:
    """The parameter layout of ``config``'s NLP for ``robot`` (None: the contract's): the margin
    as parameters where the NLP has wall slots and a margin near walls; the robot's radius
    always."""
    margin = ((config.clearance_margin_m, config.uncertainty_sigmas)
              if config.max_walls and config.walls_margin_m is not None else None)
    return ParameterLayout(config.horizon, config.max_moving, config.max_static, config.max_walls, margin,
                           margin is not None and config.walls_directional_sigma,
                           (robot or RobotParams()).radius_m)


def beyond_horizon_cost(config: PlannerConfig, P: dict, x, y):
    """The margin's penalty at :attr:`PlannerConfig.beyond_horizon_s` after the horizon's end,
    the robot standing at ``(x, y)`` (the plan's last position) and each mover carried on
    straight from its forecast's last position at the velocity of its last step (0 where
    the setting is empty, the preset has no margin or the horizon is one step)."""
    H, M, T = config.horizon, config.max_moving, config.sample_time_s
    if not config.beyond_horizon_s or config.clearance_margin_m is None or H < 2:
        return 0
    pen = 0
    e = config.margin_smoothing_m
    margin_m, sigmas = margin_terms(config, P)
    for j in range(M):
        k, k0 = (j * H + H - 1) * 2, (j * H + H - 2) * 2
        px, py = P["mov_xy"][k], P["mov_xy"][k + 1]
        vx, vy = (px - P["mov_xy"][k0]) / T, (py - P["mov_xy"][k0 + 1]) / T
        m = margin_m + sigmas * P["mov_sigma"][j * H + H - 1]
        for s in config.beyond_horizon_s:
            d = ca.sqrt((x - px - vx * s) ** 2 + (y - py - vy * s) ** 2 + 1e-12) - P["robot_r"] - P["mov_r"][j]
            violation = ca.fmax(m - d, 0.0) if e is None else _smooth_positive(m - d, e)
            pen += P["mov_on"][j] * config.clearance_penalty * violation ** 2
    return pen


def rollout_states(config: PlannerConfig, robot: RobotParams, x0, u) -> list[tuple]:
    """The states ``(x, y, heading, v_right, v_left)`` after each of the H steps of the
    increments ``u`` from ``x0`` (symbolic or numeric entries), by the robot model: the
    roll-out of the single-shooting NLP (:func:`build_problem`) and of its Hessian
    (:mod:`casadi_gpc.solvers.hessian`)."""
    x, y, th, vr, vl = x0[0], x0[1], x0[2], x0[3], x0[4]
    states = []
    for i in range(config.horizon):
        vr, vl = vr + u[2 * i], vl + u[2 * i + 1]
        x, y, th = robot_step(ca, x, y, th, vr, vl, config.sample_time_s, robot.wheel_base_m)
        states.append((x, y, th, vr, vl))
    return states


def build_problem(config: PlannerConfig, robot: RobotParams | None = None) -> GPCProblem:
    """Build the NLP of ``config`` for ``robot`` (CasADi SX, single shooting)."""
    robot = robot or RobotParams()
    H, T = config.horizon, config.sample_time_s
    layout = layout_of(config, robot)
    u = ca.SX.sym("u", 2 * H)
    p = ca.SX.sym("p", layout.size)
    P = parameter_blocks(layout, p)
    x0 = P["x0"]

    tracking = effort = turning = obst = margin_pen = 0
    poses, wheels, g = [], [], []
    for i, (x, y, th, vr, vl) in enumerate(rollout_states(config, robot, x0, u)):
        g += [vr, vl]
        effort += effort_cost(config, u[2 * i], u[2 * i + 1])
        poses.append(ca.horzcat(x, y, th))
        wheels.append(ca.horzcat(vr, vl))
        terms = state_cost(config, P, i, x, y, th, vr, vl)
        tracking, turning = tracking + terms[0], turning + terms[1]
        obst, margin_pen = obst + terms[2], margin_pen + terms[3]
    J = tracking + effort + turning + obst + margin_pen
    g = ca.vertcat(*g)
    dv = robot.max_step_change_mps(T)
    vmax = robot.max_wheel_speed_mps
    return GPCProblem(
        config=config,
        robot=robot,
        layout=layout,
        nlp={"x": u, "p": p, "f": J, "g": g},
        cost_fn=ca.Function("J", [u, p], [J], ["u", "p"], ["J"]),
        terms_fn=ca.Function("terms", [u, p], [tracking, effort, turning, obst, margin_pen], ["u", "p"],
                             ["tracking", "effort", "turning", "obstacles", "margin"]),
        rollout_fn=ca.Function("rollout", [u, p], [ca.vertcat(*poses), ca.vertcat(*wheels)], ["u", "p"],
                               ["poses", "wheels"]),
        lbx=np.full(2 * H, -dv),
        ubx=np.full(2 * H, dv),
        lbg=np.full(2 * H, -vmax),
        ubg=np.full(2 * H, vmax),
    )
