"""The GPC controller: obstacle EKFs, the NLP and its solver built once, multi-start solves
(their schedule: :mod:`casadi_gpc.planner.multistart`), a per-step time budget, and the
fallback."""
from __future__ import annotations

import math
import threading
import time
from collections import deque
from dataclasses import dataclass, field, fields, replace

import numpy as np

from .candidates import CandidateSet
from ..config import PlannerConfig, preset
from ..geometry import walls_reach_m
from ..problem.cost import GPCProblem, to_world
from ..estimation.ekf import EKFSettings, ObstacleEKF
from ..estimation.forecast_function import ForecastFunction
from ..estimation.walls_forecast import WallsForecast
from .guesses import check_guess_names
from .lanes import SolveLanes
from .multistart import MultiStart, Plan
from ..progress import ReferenceClock
from ..robot import RobotParams, brake_wheels, followed_plan, followed_wheel
from ..problem.selection import planner_parameters
from ..solvers import Backend, SolveResult
from ..estimation.tracking import TrackBank
from .tiers import BACKUP_SHARE, SolveTier, build_tier, crowd_config, crowded
from ..types import ControlDecision, Observation, ObstacleForecast

__all__ = ["Plan", "Tick", "GPCController"]

_RESULT_FIELDS = tuple(f.name for f in fields(SolveResult))

SOLVE_SHARE = 0.8
"""The share of the sample time one decision spends solving unless ``time_budget_s`` says
otherwise; the rest is for the check behind the planner and a solve that ends late. With the
whole sample time as the budget, one decision among navground's corridor walkers took 506 ms
against the 0.5 s sample time, under a load of four processes on two cores (the last solve
begun just inside the budget, then the check)."""

SOLVE_MEMORY = 50
"""How many of the controller's last solves :meth:`GPCController.decide` looks back on: a
start after the step's first is begun only while the longest of them would end within the
budget."""

_SOLVE_TIMES = threading.Lock()
"""The solve lanes' threads read and write a controller's solve times under this (one for every
controller: it is held for microseconds)."""


@dataclass(frozen=True)
class Tick:
    """One control step's NLP, as the planner poses it: what its candidates are solved on."""

    p: np.ndarray
    """The NLP parameters (``casadi_gpc.problem.cost.ParameterLayout``)."""
    x0: np.ndarray
    """The robot's state (x, y, heading, v_right, v_left)."""
    ref_speed_mps: float
    near: bool
    """Obstacles within the multi-start range (the cost is not convex)."""
    relevant: frozenset
    """The obstacles that matter now (:meth:`GPCController.plan_persistent`)."""


@dataclass
class GPCController(MultiStart):
    """The paper's GPC with an EKF per moving obstacle. ``decide(observation)`` each sample.

    Each decision carries the forecasts of every tracked mover (``forecasts``: the shield
    checks against them) and the other solved candidates, cheapest first (``alternatives``:
    what the shield tries before its manoeuvres). The planner as shipped runs behind the
    check, ``casadi_gpc.safety.Shield(GPCController(...))``: its answer must keep clear of
    the predicted discs whatever the cost's weights (``gpcnav --controller gpc``)."""

    provides_forecasts = True

    config: PlannerConfig = field(default_factory=lambda: preset("improved"))
    robot: RobotParams = field(default_factory=RobotParams)
    ekf_settings: EKFSettings = field(default_factory=EKFSettings)
    ipopt_options: dict = field(default_factory=dict)
    """Extra IPOPT options (the IPOPT backends only)."""
    compile_solver: bool = True
    """Use compiled NLP functions where the backend offers them (cached on disk)."""
    backup_solver: str | None = "ipopt-warm-compiled"
    """Re-solves, from the same start, a solve the main solver failed on (while the step's
    budget lasts; counted in ``counters['backup_solves']``). None: no second try. IPOPT's
    warm start, its NLP functions compiled when ``compile_solver`` is (the same iterates as
    uncompiled, faster the larger the NLP: 1.3 times on ``paper``'s, 4.5 on the crowd's with
    walls; docs/solvers.md, "Backup")."""

    def __post_init__(self):
        self.sample_time_s = self.config.sample_time_s
        budget = self.config.time_budget_s
        self.time_budget_s = float(SOLVE_SHARE * self.config.sample_time_s if budget is None else budget)
        """Wall time one ``decide`` may spend solving (s); later answers are not used."""
        # built once, each NLP with its solver (:mod:`casadi_gpc.planner.tiers`): the preset's,
        # and the crowd's where ``crowd_moving`` is set (built now: at its first tick it
        # would hold that decision past its sample time)
        tiers = [self.config] + [c for c in (crowd_config(self.config),) if c is not None]
        self._tiers = [build_tier(c, self.robot, self.time_budget_s, self.compile_solver, self.ipopt_options,
                                  self.backup_solver) for c in tiers]
        self._tier: SolveTier | None = None
        self._use(self._tiers[0])
        self.solver_name = self.backend.name
        self._forecast_function = ForecastFunction(self.config.sample_time_s, self.config.horizon)
        self.walls_forecast = WallsForecast.for_config(self.config)
        """The learned forecast of walkers near walls, or None (not asked for, or another sample
        time or horizon than it was trained at)."""
        self.horizon = self.config.horizon
        check_guess_names(self.config.guesses)
        period = max(1, int(round(self.config.multistart_period_s / self.config.sample_time_s)))
        memory = max(1, int(round(self.config.relevance_memory_s / self.config.sample_time_s)))
        self.candidates = CandidateSet(self.config.horizon, period, self.config.prune_ratio, memory)
        self._failure_prob, self._failure_rng = 0.0, None
        self._deadline: float | None = None
        self._started = 0
        """Solves begun in this ``decide``."""
        self._recent = deque(maxlen=SOLVE_MEMORY)
        """The wall times of the last solves (s), kept across episodes: the machine's speed."""
        self._longest = 0.0
        """The longest of :attr:`_recent`."""
        self.reset()

    @property
    def solver_info(self) -> dict:
        """Which solver this controller uses, compiled or not, and its time budget."""
        return {**self.backend.info(), "time_budget_s": self.time_budget_s,
                "backup": None if self.backup is None else self.backup.name}

    def inject_failures(self, probability: float, rng: np.random.Generator | None = None) -> None:
        """Make each step's solve fail with ``probability`` (drawn from ``rng``), which leads
        to the fallback, counted in ``counters['injected_failures']`` and ``['fallbacks']``."""
        if not 0.0 <= probability <= 1.0:
            raise ValueError(f"failure probability must be in [0, 1], got {probability}")
        self._failure_prob = float(probability)
        self._failure_rng = rng if rng is not None else np.random.default_rng()

    # --- state -----------------------------------------------------------------------
    def reset(self) -> None:
        self.clock = ReferenceClock(self.config.sample_time_s, self.config.max_lead_m)
        self._warm: Plan | None = None
        self._pending: list[str] = []
        """The fixed guesses of a full multi-start still to solve (``PlannerConfig.cold_starts``)."""
        self._since_guess = self.config.cold_start_gap  # ticks since a queued guess was solved
        self._walls_in_slots: list = []
        self._last_wheels: np.ndarray | None = None
        self._path_xy: np.ndarray | None = None
        """The robot's predicted positions at steps 1..H of the last plan (for relevance)."""
        if hasattr(self, "candidates"):
            self.candidates.reset()
        if self.walls_forecast is not None:
            self.walls_forecast.reset()
        self.counters = {"solves": 0, "failed_solves": 0, "fallbacks": 0, "multistart": 0,
                         "missed_measurements": 0, "outliers": 0, "over_budget": 0, "budget_skips": 0,
                         "injected_failures": 0, "backup_solves": 0, "backup_successes": 0,
                         "unestimated_tracks": 0, "left_out": 0, "full_multistarts": 0, "walls_forecasts": 0}
        # the obstacle filters count their events (missed, outliers, unestimated) here too
        self.bank = TrackBank(self.config.sample_time_s, self.ekf_settings, self.counters,
                              straight=self.config.forecast == "straight")

    @property
    def tracks(self) -> dict[int, ObstacleEKF]:
        """The obstacle filters by obstacle id."""
        return self.bank.filters

    # --- estimation --------------------------------------------------------------------
    def estimate(self, obs: Observation) -> list[ObstacleForecast]:
        """Fuse this sample's measurements and predict every track over the horizon; near
        walls, with each walker's learned forecast beside (``PlannerConfig.walls_forecast``)."""
        tracks = self.bank.step(obs.moving, obs.t_s)
        forecasts = self.bank.forecasts(tracks, self.config.horizon, self._forecast_function)
        if obs.walls and self.walls_forecast is not None:
            forecasts = self.walls_forecast.add(obs, forecasts, self.counters)
        return forecasts

    def desired_poses(self, obs: Observation) -> np.ndarray:
        """Advance the reference clock; the desired poses at steps 0..H, shape (H + 1, 3)
        (step 0: where the reference point is now)."""
        path = obs.reference
        self.clock.update(path, obs.t_s, (obs.robot.x_m, obs.robot.y_m))
        # the arc lengths s + k v T, k = 0..H, clipped to the path (ReferenceClock.horizon_arclengths)
        poses = path.poses_along(self.clock.s_m, path.speed_mps * self.config.sample_time_s, self.config.horizon + 1)
        return np.array(poses)

    # --- solving -----------------------------------------------------------------------
    @property
    def lanes(self) -> SolveLanes:
        """The backend and its forks that solve a tick's starts at once (built on first use,
        and again if ``backend`` is replaced)."""
        if self._lanes is None or self._lanes.backends[0] is not self.backend:
            self._lanes = SolveLanes(self.backend, self.config.solve_lanes)
        return self._lanes

    def _use(self, tier: SolveTier) -> None:
        """Solve on ``tier``'s NLP from now on (``problem``, ``backend``, ``backup``, the lanes
        and the roll-out are its; a backend replaced from outside stays with its tier)."""
        if tier is self._tier:
            return
        if self._tier is not None:
            self._tier.backend, self._tier.backup, self._tier.lanes = self.backend, self.backup, self._lanes
        self._tier = tier
        self.problem: GPCProblem = tier.problem
        self.backend: Backend = tier.backend
        self.backup: Backend | None = tier.backup
        self._lanes: SolveLanes | None = tier.lanes
        self._ref_slice, self._rollout = tier.ref_slice, tier.rollout

    @property
    def nlps(self) -> tuple[GPCProblem, ...]:
        """The NLPs this controller solves, in order: the preset's, and the crowd's where it
        has one (:mod:`casadi_gpc.planner.tiers`); :attr:`problem` is the one in use."""
        return tuple(tier.problem for tier in self._tiers)

    def _use_for(self, p: np.ndarray) -> None:
        """Solve on the tier whose NLP takes the parameters ``p`` (a tick posed earlier, a
        parameter vector packed outside; the current tier if none matches)."""
        for tier in self._tiers:
            if tier.problem.layout.size == np.size(p):
                self._use(tier)
                return

    def solve_many(self, p: np.ndarray, starts: list[tuple]) -> list[Plan]:
        """The starts ``(guess, u0, lam_x, lam_g)`` solved at once on the controller's lanes
        (:mod:`casadi_gpc.planner.lanes`) by its backend (and, where that fails, by the backup solver),
        in the order given. Inside ``decide``, a start is left out (counted in ``budget_skips``)
        when the step's time budget is spent or, after the step's first solve, when the longest
        of the controller's recent solves would end past it; an answer that arrives after the
        budget is marked failed (``over_budget``): the loop does not use late answers."""
        answers = self.lanes.solve_all([(p, u0, lx, lg) for _, u0, lx, lg in starts], self._no_time_for_a_solve,
                                      self._solved_in)
        out = []
        for a, (guess, u0, lx, lg) in zip(answers, starts):
            if a is None:
                self.counters["budget_skips"] += 1  # not started: the step's budget is spent
                continue
            out.append(self._finish(p, a[0], a[1], guess, u0, lx, lg))
        return out

    def _finish(self, p, r, done_s: float, guess: str, u0, lam_x, lam_g) -> Plan:
        """A solver's answer ``r`` (there at ``done_s``) as a :class:`Plan`: the backup
        solver's if the backend failed and time is left; failed if late; counted."""
        if not r.success and self.backup is not None and self._time_left() >= BACKUP_SHARE * self.time_budget_s:
            first = r
            self.counters["backup_solves"] += 1
            r = self.backup.solve(p, u0, lam_x, lam_g)
            done_s = time.perf_counter()
            self.counters["backup_successes"] += int(r.success)
            r = replace(r, status=f"{self.backup.name} after {self.solver_name}: {first.status} -> {r.status}",
                        solve_time_s=first.solve_time_s + r.solve_time_s)
        elif not r.success and self.backup is not None:
            self.counters["backup_skips"] = self.counters.get("backup_skips", 0) + 1  # too little time left
        plan = Plan(*(getattr(r, n) for n in _RESULT_FIELDS), guess=guess)
        if self._deadline is not None and done_s > self._deadline:
            self.counters["over_budget"] += 1
            plan = replace(plan, success=False, status=f"over the time budget of {self.time_budget_s:g} s")
        self.counters["solves"] += 1
        if not plan.success:
            self.counters["failed_solves"] += 1
        return plan

    def near_obstacles(self, x0: np.ndarray, forecasts, statics) -> frozenset:
        """The obstacles (``("moving", id)``, ``("static", index)``) within the robot's reach
        in one horizon plus ``multistart_range_m``: the ones that make the cost non-convex."""
        cfg, robot = self.config, self.robot
        reach = robot.max_wheel_speed_mps * cfg.horizon * cfg.sample_time_s + cfg.multistart_range_m
        near = []
        if len(forecasts):  # all at once: numpy's per-call cost, not the arithmetic, is what costs here
            q = np.array([f.means_m for f in forecasts], dtype=float)       # (n, H, 2)
            close = np.hypot(q[..., 0] - x0[0], q[..., 1] - x0[1]).min(axis=1) < reach
            near = [("moving", f.obstacle_id) for f, c in zip(forecasts, close) if c]
        near += [("static", j) for j, s in enumerate(statics)
                 if math.hypot(s.position_m[0] - x0[0], s.position_m[1] - x0[1]) < reach]
        return frozenset(near)

    def _no_time_for_a_solve(self) -> bool:
        """Whether a start about to begin is left out: the step's budget is spent, or this is
        not the step's first solve and the longest of the last :data:`SOLVE_MEMORY` would end
        past the budget. The first is always tried while time is left (the likeliest answer,
        and the solves' times stay the machine's own); a C solve cannot be stopped once begun,
        so this is what keeps the decision within its sample time."""
        if self._deadline is None:
            return False
        with _SOLVE_TIMES:  # lanes ask from their threads
            left = self._deadline - time.perf_counter()
            if left <= 0.0 or (self._started and left < self._longest):
                return True
            self._started += 1
            return False

    def _solved_in(self, seconds: float) -> None:
        """A solve's wall time, told by its lane as it ends."""
        with _SOLVE_TIMES:
            self._recent.append(seconds)
            self._longest = max(self._recent)

    def _time_left(self) -> float:
        """Seconds left of this step's budget (infinite outside ``decide``)."""
        return math.inf if self._deadline is None else self._deadline - time.perf_counter()

    # --- the step ----------------------------------------------------------------------
    def decide(self, obs: Observation) -> ControlDecision:
        self._deadline = time.perf_counter() + self.time_budget_s
        self._started = 0
        try:
            return self._decide(obs)
        finally:
            self._deadline = None

    def pose(self, obs: Observation, forecasts) -> tuple[Tick, object]:
        """This step's NLP (:class:`Tick`) and the obstacle selection behind it: the
        reference clock advanced, the NLP chosen (the crowd's where more movers are tracked
        than the preset's slots hold, :mod:`casadi_gpc.planner.tiers`), the movers chosen for its
        slots, the parameters packed."""
        ref = self.desired_poses(obs)
        x0 = obs.robot.as_array()
        path = self._predicted_path(ref)
        crowd = len(self._tiers) > 1 and crowded(self.config, forecasts)
        self._use(self._tiers[int(crowd)])
        p, sel = planner_parameters(self.problem.layout, x0, ref, forecasts, obs.static, self.problem.config,
                                    path, obs.walls, walls_reach_m(self.robot, self.config.horizon * self.sample_time_s))
        self._walls_in_slots = sel.walls
        for key, n in (("left_out", sel.left_out), ("crowd_ticks", crowd), ("walls_left_out", sel.walls_left_out),
                       ("walls_margin_ticks", sel.near_walls)):  # the margin near walls where it applied
            if n:
                self.counters[key] = self.counters.get(key, 0) + n
        near_ids = self.near_obstacles(x0, sel.forecasts, sel.statics)
        if near_ids:
            self.counters["multistart"] += 1
        relevant = sel.relevant | {k for k in near_ids if k[0] == "static"}
        return Tick(p, x0, float(obs.reference.speed_mps), bool(near_ids), relevant), sel

    def solve_tick(self, tick: Tick) -> tuple[Plan | None, list[Plan]]:
        """The best plan of one step and every solve it took (persistent candidates, or the
        full multi-start, as ``PlannerConfig.candidates`` says)."""
        self._use_for(tick.p)
        if self.config.candidates == "persistent":
            return self.plan_persistent(tick.p, tick.x0, tick.ref_speed_mps, tick.near, tick.relevant)
        return self.plan(tick.p, tick.x0, tick.ref_speed_mps, tick.near, self._warm)

    def _decide(self, obs: Observation) -> ControlDecision:
        held = obs.with_wheels_within(self.robot.max_wheel_speed_mps)
        if held is not None:  # planned from the wheels' limits, counted
            obs = held
            self.counters["wheel_state_held"] = self.counters.get("wheel_state_held", 0) + 1
        forecasts = self.estimate(obs)
        tick, sel = self.pose(obs, forecasts)
        p, x0 = tick.p, tick.x0
        if self._failure_prob > 0.0 and self._failure_rng.random() < self._failure_prob:
            self.counters["injected_failures"] += 1
            return self._fallback(obs, "injected solver failure", forecasts)
        best, candidates = self.solve_tick(tick)
        if best is None:
            statuses = sorted({c.status for c in candidates}) or ["no solve started within the time budget"]
            return self._fallback(obs, "all solves failed: " + ", ".join(statuses), forecasts)
        self._warm = best
        self._rollout(best.u, p)
        poses, wheels = to_world(self._rollout.output(0), x0), self._rollout.output(1)
        self._last_wheels = wheels
        self._path_xy = poses[:, :2]
        # the solvers meet their bounds to their tolerance (IPOPT's 1e-8): a plan 6e-9 m/s beyond
        # the wheel or rate limit was clipped by the robot and counted so (clipped_commands,
        # shield_candidate_limited: every count of both in three runs); what is decided is the plan
        # as the robot follows it
        r = obs.robot
        wheels = followed_plan(r.v_right_mps, r.v_left_mps, wheels, self.robot.max_step_change_mps(
            self.config.sample_time_s), self.robot.max_wheel_speed_mps)
        return ControlDecision(
            float(wheels[0, 0]), float(wheels[0, 1]), False, best.guess, wheels, poses, best.cost,
            {"iterations": best.iterations, "candidates": len(candidates), "selected": len(sel.forecasts),
             "solver": self.solver_name, "solve_time_s": sum(c.solve_time_s for c in candidates)},
            forecasts=tuple(forecasts), alternatives=self._alternatives(best, candidates, x0))

    def _predicted_path(self, ref: np.ndarray) -> np.ndarray:
        """Where the robot is predicted to be at steps 1..H: its last plan shifted by a step
        (the last position held), or, without one, the desired poses."""
        if self._path_xy is None:
            return ref[1:, :2]
        return np.vstack([self._path_xy[1:], self._path_xy[-1:]])

    def _alternatives(self, best: Plan, candidates: list[Plan], x0: np.ndarray) -> tuple:
        """The other solved candidates' wheel-speed plans (H, 2), cheapest first, one per
        distinct optimum (increments within 1e-4 m/s of a kept one are the same)."""
        H = self.config.horizon
        kept, out = [np.asarray(best.u)], []
        for c in sorted((c for c in candidates if c.success and c is not best), key=lambda c: c.cost):
            u = np.asarray(c.u)
            if any(np.max(np.abs(u - k)) <= 1e-4 for k in kept):
                continue
            kept.append(u)
            out.append(x0[3:5] + np.cumsum(u.reshape(H, 2), axis=0))
        return tuple(out)

    def _fallback(self, obs: Observation, reason: str, forecasts=()) -> ControlDecision:
        """The shifted previous plan if there is one, else braking within the limits."""
        self.counters["fallbacks"] += 1
        # a spread multi-start's queue is kept: the next tick tries the next guess, not the
        # one that just failed again
        forecasts = tuple(forecasts)
        self._path_xy = None
        self.candidates.reset()
        dv = self.robot.max_step_change_mps(self.config.sample_time_s)
        if self._warm is not None and self._last_wheels is not None and len(self._last_wheels) > 1:
            wheels = self._last_wheels[1:]
            self._last_wheels = wheels
            self._warm = Plan(np.concatenate([self._warm.u[2:], np.zeros(2)]), float("nan"), True, "shifted",
                              0, guess="shifted")
            self.candidates.restart_from(self._warm)
            vr, vl = (followed_wheel(v, float(w), dv, self.robot.max_wheel_speed_mps) for w, v in
                      zip(wheels[0], (obs.robot.v_right_mps, obs.robot.v_left_mps)))
            return ControlDecision(vr, vl, True, "shifted previous plan; " + reason, forecasts=forecasts)
        self._warm = None
        vr, vl = brake_wheels(obs.robot.v_right_mps, obs.robot.v_left_mps, dv)
        return ControlDecision(vr, vl, True, "brake; " + reason, forecasts=forecasts)
