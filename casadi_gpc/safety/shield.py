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
(:class:`~casadi_gpc.tracking.TrackBank`, the GPC and the network do) says so with a true
``provides_forecasts`` and hands its forecasts over in every decision
(``ControlDecision.forecasts``); the shield checks against those, so the estimation is not
done twice. For any other controller the shield runs its own bank on the observations.

The check's horizon is the controller's own (``horizon`` or ``config.horizon``: the
forecasts cover it) or, for a controller without one, :data:`DEFAULT_HORIZON_S` worth of its
samples.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..ekf import EKFSettings
from ..robot import RobotParams
from ..tracking import TrackBank
from ..types import ControlDecision, Observation
from .check import shared_batch
from .filter import SafetyFilter

__all__ = ["Shield", "DEFAULT_HORIZON_S"]

DEFAULT_HORIZON_S = 6.0
"""The look-ahead of the check for a controller without a horizon of its own (the
``improved`` planner's: 12 samples of 0.5 s)."""


def _policy_horizon(policy, sample_time_s: float) -> int:
    for h in (getattr(policy, "horizon", None), getattr(getattr(policy, "config", None), "horizon", None)):
        if isinstance(h, int) and h >= 1:
            return h
    return max(1, int(round(DEFAULT_HORIZON_S / sample_time_s)))


class Shield:
    """``policy`` behind the safety check (see the module text).

    Parameters
    ----------
    policy : object answering the Policy protocol
        The controller whose answers are checked.
    robot : RobotParams, optional
        The robot's geometry and limits (default: the contract's robot).
    fallback : object with ``decide(observation)``, optional
        The planner the check hands over to when the controller's answer fails (e.g. the
        GPC in a :class:`~casadi_gpc.safety.StandbyPlanner` behind a network).
    margin_m, sigmas, substeps, trust_planner_s
        As :class:`~casadi_gpc.safety.SafetyFilter`.
    horizon : int, optional
        Intervals checked (default: the controller's horizon, see the module text).
    trust_plans : bool
        The controller is a planner that replans at every sample (the GPC): its plan, or
        one of its alternatives, passes when it keeps the margin for the filter's
        ``trust_planner_s`` (default 3 s), as the fallback planner's answer does; a
        violation later in the horizon, where the forecast's uncertainty has grown, is left
        to its next plans. Otherwise (a network, a reactive peer) the whole horizon counts.
    ekf_settings : EKFSettings, optional
        The shield's own obstacle filters, for a controller that provides no forecasts.
    previous_plan : bool
        Keep the plan let through at each sample, shifted by one step (the last wheel speeds
        held, as the planner shifts its own), and offer it after the controller's own
        alternatives when its answer fails the check: the safe candidate of Hose et al.'s
        safety-augmented approximate MPC, for a controller that outputs whole plans (a plan
        network). Taken, it is the controller's answer (not a fallback), with source
        ``previous_plan``, counted in ``shield_previous_plan_used`` (and, as every alternative,
        in ``shield_alternative_used``).
    rollouts : bool
        For a controller that answers a command without a plan and can roll itself forward
        (a ``rollout()`` method: :meth:`nn_export.OnnxPolicy.rollout`): when the command
        alone fails the check, its roll-out is judged as a plan (over the whole horizon, or
        for ``trust_rollout_s``) before the check steps in (:meth:`SafetyFilter.filter`'s
        ``plan_on_demand``; counted in ``shield_rollouts`` and ``shield_rollout_passed``; the
        plan let through is in the decision's ``info["rollout_wheels_mps"]``).
    trust_rollout_s : float, optional
        With ``rollouts``: a roll-out that keeps the margin this long passes, even if it
        fails later in the horizon (counted in ``shield_rollout_trusted``); None: the whole
        horizon (:class:`~casadi_gpc.safety.SafetyFilter`'s ``trust_rollout_s``).
    safer_alternatives : bool
        With ``trust_plans``: a plan that passes on the trust time alone gives way to the
        first of the controller's alternatives that keeps the margin over the whole horizon
        (an intervention, not a fallback; counted in ``shield_alternative_safer``).
        :data:`~casadi_gpc.safety.SAFER_ALTERNATIVES` per preset.
    """

    def __init__(self, policy, robot: RobotParams | None = None, fallback=None, margin_m: float = 0.05,
                 sigmas: float = 2.0, substeps: int = 4, trust_planner_s: float | None = None,
                 horizon: int | None = None, ekf_settings: EKFSettings | None = None, trust_plans: bool = False,
                 previous_plan: bool = False, rollouts: bool = False, trust_rollout_s: float | None = None,
                 safer_alternatives: bool = False):
        for attr in ("decide", "reset"):
            if not callable(getattr(policy, attr, None)):
                raise TypeError(f"the shielded controller must have a {attr}() method")
        T = getattr(policy, "sample_time_s", None)
        if not isinstance(T, (int, float)) or not (math.isfinite(T) and T > 0):
            raise TypeError(f"the shielded controller's sample_time_s must be a positive number, got {T!r}")
        self.policy = policy
        self.sample_time_s = float(T)
        self.robot = robot or getattr(policy, "robot", None) or RobotParams()
        self.horizon = int(horizon) if horizon is not None else _policy_horizon(policy, self.sample_time_s)
        self.filter = SafetyFilter(self.robot, self.sample_time_s, self.horizon, margin_m, sigmas, substeps,
                                   fallback=fallback, trust_planner_s=trust_planner_s,
                                   trust_rollout_s=trust_rollout_s, safer_alternatives=safer_alternatives)
        self.uses_policy_forecasts = bool(getattr(policy, "provides_forecasts", False))
        self.trust_plans = bool(trust_plans)
        self.previous_plan = bool(previous_plan)
        self._rollout = getattr(policy, "rollout", None) if rollouts else None
        if rollouts and not callable(self._rollout):
            raise TypeError("rollouts=True needs a controller with a rollout() method")
        self.ekf_settings = ekf_settings or EKFSettings()
        self._names: dict[str, str] = {}
        self.reset()

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
        return [self._bank.forecast(m, ekf, H) for m, ekf in self._bank.step(obs.moving)]

    def decide(self, obs: Observation) -> ControlDecision:
        """The controller's decision, checked (see the class). Its ``info`` adds
        ``safety_time_s`` (the check's own time, the fallback's included when it steps in,
        and this layer's own filters' updates and forecasts for a controller without
        forecasts) and ``forecast_time_s`` (the controller's forecasts, made here when its
        decision had not read them)."""
        dec = self.policy.decide(obs)
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
        own = plan is not None and plan[0, 0] == dec.v_right_mps and plan[0, 1] == dec.v_left_mps
        cand = plan if own else (dec.v_right_mps, dec.v_left_mps)
        v = self.filter.filter(obs, cand, forecasts, obs.static, dec.planned_poses if own else None,
                               dec.alternatives, self.filter.trust_planner_s if self.trust_plans else None,
                               self._kept, None if own else self._rollout)
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
        # the controller's own alternative, or its previous plan, is its answer, not a fallback; the rest are
        fallback = not (v.source.startswith("alternative") or v.source == "previous_plan")
        return ControlDecision(v.v_right_mps, v.v_left_mps, fallback, v.reason, v.planned_wheels_mps, None,
                               info={**info, "controller_wheels_mps": (dec.v_right_mps, dec.v_left_mps),
                                     "safety_source": v.source}, forecasts=dec.forecasts)
