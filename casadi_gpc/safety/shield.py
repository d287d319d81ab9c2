"""Any controller behind the safety check: the one controller-agnostic layer (numpy only).

:class:`Shield` wraps an object that answers the Policy protocol (``sample_time_s``,
``reset()``, ``decide(observation) -> ControlDecision``) and answers it too. Each sample it
asks the controller, then lets its answer through :class:`~casadi_gpc.safety.SafetyFilter`:
the controller's own plan (or its command, with a way out) checked against the predicted
obstacle discs inflated by their uncertainty over the horizon; when that fails, the
controller's alternatives (best first), the fallback planner (if one was given) and the
filter's manoeuvres take over, in that order (the package text has the rules). Every
intervention is counted, in ``counters["interventions"]``; one that takes the fallback
planner's answer or a manoeuvre marks the decision as a fallback.

Forecasts: a controller that tracks the obstacles with the one EKF bank
(:class:`~casadi_gpc.estimation.tracking.TrackBank`, the GPC and the network do) says so with a true
``provides_forecasts`` and hands its forecasts over in every decision
(``ControlDecision.forecasts``); the shield checks against those, so the estimation is not
done twice. For any other controller the shield runs its own bank on the observations.

The check's horizon is the controller's own (``horizon`` or ``config.horizon``: the
forecasts cover it) or, for a controller without one, :data:`DEFAULT_HORIZON_S` worth of its
samples.
"""
from __future__ import annotations

import time
from numbers import Integral

import numpy as np

from ..estimation.ekf import EKFSettings
from ..robot import RobotParams
from ..estimation.tracking import TrackBank
from ..types import ControlDecision, Observation, ProtocolError, checked_decision, policy_class_name, positive_seconds
from .check import shared_batch
from .filter import SafetyFilter
from .settings import CheckSettings
from .standby import StandbyPlanner
from ..geometry import walls_reach_m
from .walls import wall_segments_within

__all__ = ["Shield", "DEFAULT_HORIZON_S"]

DEFAULT_HORIZON_S = 6.0
"""The look-ahead of the check for a controller without a horizon of its own (the
``improved`` planner's: 12 samples of 0.5 s)."""


def _policy_horizon(policy, sample_time_s: float) -> int:
    for h in (getattr(policy, "horizon", None), getattr(getattr(policy, "config", None), "horizon", None)):
        if isinstance(h, Integral) and not isinstance(h, bool) and h >= 1:  # numpy's integers too
            return int(h)
    return max(1, int(round(DEFAULT_HORIZON_S / sample_time_s)))


def _plan_refused(policy, plan, horizon: int) -> ProtocolError:
    """The one line for a controller whose plan is not ``(horizon, 2)``: the check judges a plan
    over its own horizon (a plan of another length failed deep in the check, or as an IndexError)."""
    return ProtocolError(f"{policy_class_name(policy)}.decide() returned planned_wheels_mps of shape "
                         f"{np.shape(plan)}, not ({horizon}, 2): the check layer's horizon is {horizon} samples (the "
                         f"controller's horizon attribute, else {DEFAULT_HORIZON_S:g} s of its samples; the Policy "
                         f"protocol)")


class Shield:
    """``policy`` behind the safety check (see the module text).

    Parameters
    ----------
    policy : object answering the Policy protocol
        The controller whose answers are checked.
    robot : RobotParams, optional
        The robot's geometry and limits (default: the controller's ``robot``, else the
        contract's robot).
    settings : CheckSettings, optional
        What the check trusts from this controller, for how long, and what it falls back on
        (:class:`~casadi_gpc.safety.CheckSettings`; default: nothing trusted, the whole
        horizon checked, the manoeuvres behind). The controller registry
        (``gpcnav.controllers``) declares them per controller.
    planner_config : PlannerConfig, optional
        With ``settings.fallback == "planner"``: the settings of the GPC kept on standby
        (default: the controller's own ``config``). The planner is made here, so CasADi is
        imported only by a check that falls back on it.
    standby : object with ``decide(observation)``, optional
        A planner to keep on standby instead of the GPC (``settings.fallback`` must be
        ``planner``); for tests and for users with a planner of their own.

    A controller that provides no forecasts is checked against the shield's own obstacle
    filters, stepped at the controller's sample time with the planner's noise per second
    (:meth:`~casadi_gpc.estimation.ekf.EKFSettings.for_sample_time`: a 6 s check at 0.1 s
    would otherwise lose every heading).
    """

    def __init__(self, policy, robot: RobotParams | None = None, settings: CheckSettings | None = None,
                 planner_config=None, standby=None):
        for attr in ("decide", "reset"):
            if not callable(getattr(policy, attr, None)):
                raise TypeError(f"the shielded controller must have a {attr}() method")
        T = getattr(policy, "sample_time_s", None)
        if not positive_seconds(T):
            raise TypeError(f"the shielded controller's sample_time_s must be a positive number, got {T!r}")
        settings = settings or CheckSettings()
        self.settings = settings
        self.policy = policy
        self.sample_time_s = float(T)
        self.robot = robot or getattr(policy, "robot", None) or RobotParams()
        self.horizon = settings.horizon if settings.horizon is not None else _policy_horizon(policy, self.sample_time_s)
        fallback = self._standby(settings, planner_config, standby)
        self.filter = SafetyFilter(self.robot, self.sample_time_s, self.horizon, settings.margin_m, settings.sigmas,
                                   settings.substeps, fallback=fallback, trust_planner_s=settings.trust_planner_s,
                                   trust_rollout_s=settings.trust_rollout_s,
                                   safer_alternatives=settings.safer_alternatives, search=settings.search,
                                   search_two_phase=settings.search_two_phase,
                                   search_near_walls=settings.search_near_walls,
                                   walls_margins=None if settings.walls_margin_m is None else
                                   (settings.walls_margin_m, settings.walls_sigmas),
                                   robust_drive_in=settings.robust_drive_in,
                                   robust_drive_ties=settings.robust_drive_ties)
        self.uses_policy_forecasts = bool(getattr(policy, "provides_forecasts", False))
        self.trust_plans = settings.trust_plans
        self.previous_plan = settings.previous_plan
        self._rollout = getattr(policy, "rollout", None) if settings.rollouts else None
        if settings.rollouts and not callable(self._rollout):
            raise TypeError("rollouts=True needs a controller with a rollout() method")
        self.ekf_settings = EKFSettings().for_sample_time(self.sample_time_s)
        self._names: dict[str, str] = {}
        self.reset()

    def _standby(self, settings: CheckSettings, planner_config, standby):
        """The planner kept on standby (``fallback == "planner"``), or None."""
        if settings.fallback != "planner":
            if standby is not None:
                raise ValueError("a standby planner was given but settings.fallback is not 'planner'")
            return None
        if standby is None:
            from ..planner.gpc import GPCController  # CasADi: only for a check that falls back on the planner
            config = planner_config if planner_config is not None else getattr(self.policy, "config", None)
            if config is None:
                raise ValueError("fallback 'planner' needs a planner_config (the controller has no config)")
            standby = GPCController(config, self.robot)
        return standby if isinstance(standby, StandbyPlanner) else StandbyPlanner(standby)

    def _walls_near(self, obs: Observation):
        """The wall segments the robot could reach within the check's horizon (its top speed
        for the whole horizon, its radius, and a margin of a metre beyond), or None."""
        if not obs.walls:
            return None
        reach = walls_reach_m(self.robot, self.horizon * self.sample_time_s)
        return wall_segments_within(obs.walls, (obs.robot.x_m, obs.robot.y_m), reach)

    @property
    def config(self):
        """The shielded controller's planner settings, when it has them."""
        return getattr(self.policy, "config", None)

    def reset(self) -> None:
        self.policy.reset()
        self.filter.reset()
        self._bank = None if self.uses_policy_forecasts else TrackBank(self.sample_time_s, self.ekf_settings)
        self._kept: np.ndarray | None = None  # the plan let through last, shifted (previous_plan)

    @property
    def counters(self) -> dict:
        """The controller's counters, ``interventions``, and the check's other counters
        (prefixed ``shield_``; with its own obstacle filters, theirs too), current when read."""
        c = dict(getattr(self.policy, "counters", {}))
        names = self._names
        for k, n in self.filter.counters.items():
            name = names.get(k)
            if name is None:
                name = names[k] = k if k == "interventions" else "shield_" + k
            c[name] = n
        if self.previous_plan:
            c.setdefault("shield_previous_plan_used", 0)
        if self._bank is not None:  # the shield's own filters: missed, outliers, tracks seen once
            for k, n in self._bank.counters.items():
                c["shield_" + k] = c.get("shield_" + k, 0) + n
        fallback = self.filter.fallback
        if fallback is not None:
            for k in ("solves", "failed_solves", "fallbacks"):  # the standby planner's own work
                n = getattr(fallback, "counters", {}).get(k)
                if n is not None:
                    c["shield_fallback_" + k] = n
        return c

    def _forecasts(self, obs: Observation, dec: ControlDecision):
        if self._bank is None:
            if dec.forecasts is None:
                raise ValueError("the shielded controller says it provides forecasts but its decision has none")
            return dec.forecasts
        H = self.horizon
        return [self._bank.forecast(m, ekf, H) for m, ekf in self._bank.step(obs.moving, obs.t_s)]

    def inject_failures(self, probability: float, rng=None) -> bool:
        """The planner's solve failures (``[faults] solver_failure_prob``), passed on to the
        controller behind this layer where it takes them (the GPC): the default ``--controller
        gpc`` runs behind the layer, and the fault was never applied there while the documents
        recorded it. False where the controller has no solver to fail (the simulator says so)."""
        inner = getattr(self.policy, "inject_failures", None)
        return False if inner is None else inner(probability, rng)

    def decide(self, obs: Observation) -> ControlDecision:
        """The controller's decision, checked (see the class). Its ``info`` adds
        ``safety_time_s`` (the check's own time, the fallback's included when it steps in,
        and this layer's own filters' updates and forecasts for a controller without
        forecasts) and ``forecast_time_s`` (the controller's forecasts, made here when its
        decision had not read them)."""
        held = obs.with_wheels_within(self.robot.max_wheel_speed_mps)
        if held is not None:  # the controller and the check start from the wheels' limits, counted
            obs = held
            self.filter.counters["wheel_state_held"] = self.filter.counters.get("wheel_state_held", 0) + 1
        dec = checked_decision(self.policy.decide(obs), self.policy)
        t_forecasts = time.perf_counter()
        if self._bank is None and dec.forecasts:
            # a controller's forecasts are its estimation's, made when first read by some
            # (the network's track estimates: its bare decision needs none): made here, off
            # the check's clock (safety_time_s), as they were inside the decision before; a
            # crowd's, made together, as the arrays the check takes whole
            batch = shared_batch(dec.forecasts)
            if batch is not None:
                batch.arrays
            else:
                for f in dec.forecasts:
                    f.means_m, f.covs_m2
        t0 = time.perf_counter()
        forecasts = self._forecasts(obs, dec)
        # the plan is the candidate's own continuation only when its first step is the command
        plan = dec.planned_wheels_mps
        if plan is not None and np.shape(plan) != (self.horizon, 2):
            raise _plan_refused(self.policy, plan, self.horizon)
        own = plan is not None and plan[0, 0] == dec.v_right_mps and plan[0, 1] == dec.v_left_mps
        cand = plan if own else (dec.v_right_mps, dec.v_left_mps)
        v = self.filter.filter(obs, cand, forecasts, obs.static, dec.planned_poses if own else None,
                               dec.alternatives, self.filter.trust_planner_s if self.trust_plans else None,
                               self._kept, None if own else self._rollout,
                               self._walls_near(obs))  # every option judged against the walls
        if self.previous_plan:
            p = v.planned_wheels_mps
            self._kept = None if p is None or p.shape != (self.horizon, 2) else np.concatenate([p[1:], p[-1:]])
        info = dec.info  # the decision is new each step: annotate it in place
        info["safety_time_s"], info["forecast_time_s"] = time.perf_counter() - t0, t0 - t_forecasts
        info["safety_clearance_m"] = v.check.min_clearance_m
        if v.check.continuation == "roll-out":  # let through on the controller's own roll-out: the plan judged
            info["rollout_wheels_mps"] = v.planned_wheels_mps
        if not v.intervened:
            return dec
        # the controller's own answer kept (no option did better), its alternative or its previous plan is
        # its answer, not a fallback; the fallback planner's and a manoeuvre are (until 2026-12-02 a kept
        # candidate was counted a fallback too, an alternative kept so was not)
        fallback = not (v.source == "candidate" or v.source.startswith("alternative") or v.source == "previous_plan")
        return ControlDecision(v.v_right_mps, v.v_left_mps, fallback, v.reason, v.planned_wheels_mps, None,
                               info={**info, "controller_wheels_mps": (dec.v_right_mps, dec.v_left_mps),
                                     "safety_source": v.source}, forecasts=dec.forecasts)
