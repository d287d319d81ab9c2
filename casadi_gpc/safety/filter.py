"""The safety filter: each sample, let the candidate through when the check passes it, or
intervene: the fallback planner, else the best manoeuvre, else the candidate kept and said
so; every check and intervention counted (numpy only; see :mod:`casadi_gpc.safety`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..robot import RobotParams
from ..types import ControlDecision, Observation
from .check import SafetyCheck
from .screen import QuickScreen
from .search import WayOutSearch

__all__ = ["ROLLOUT_TRUST_S", "SafetyVerdict", "SafetyFilter"]

ROLLOUT_TRUST_S = 4.5
"""How long a one-command network's roll-out must keep the margin to pass, behind the planner
on standby (``gpcnav --controller nn``). Measured with the shipped networks on circle-crossing
with 5 and 10 ORCA walkers, square-crossing and random-multi (seeds 1 to 3) and random (seeds
1 and 2), 200 episodes each, the planner with its 10 mover slots: 4.5 s collided in none of
the 2 600, 4 s in 2 and the whole horizon (6 s) in 1 of the 600 among 10 walkers, with up
to 2.3 times more interventions than 4 s and 2.7-5 times fewer than the whole horizon. 4.5 s was
chosen on those same episodes. 3 s let one more collision through (seed 1, 10 walkers, the
planner's former 6 slots). docs/nn-crowds.md, "The network's roll-out as its plan"."""


SAFER_ALTERNATIVES = {"paper": False, "improved": True}
"""Per preset, whether the planner's plan that passes on trust alone gives way to one of its
own alternatives that keeps the margin over the whole horizon (:class:`SafetyFilter`'s
``safer_alternatives``, ``gpcnav --controller gpc``). Measured behind the check, 200
episodes each, seed 1 (navground's Antipodal scene: seeds 1-200): under ``improved`` the one
collision of the Antipodal scene goes (199 -> 200 reached, smallest clearance -0.027 ->
0.035 m), the crowds keep their outcomes at 0.2-1.4 s more to the goal, and
``random``, ``random-multi`` and ``encounters`` are unchanged but for the swaps. Under
``paper`` it changed the planner's Fig. 7.1 and 7.2 (its plans predict violations 6-8 s
ahead, in the paper's 9 s horizon), the figure a reader puts beside the paper: off there.
docs/peers.md."""


def safer_alternatives_for(config) -> bool:
    """:data:`SAFER_ALTERNATIVES` for a planner config (off for a preset it does not name)."""
    return SAFER_ALTERNATIVES.get(getattr(config, "name", None), False)


@dataclass(slots=True)
class SafetyVerdict:
    """What the filter lets through."""

    v_right_mps: float
    v_left_mps: float
    intervened: bool
    reason: str
    """Why it intervened and what replaced the candidate (empty when accepted)."""
    source: str
    """``"candidate"``, ``"alternative:<i>"`` (the controller's i-th alternative),
    ``"previous_plan"`` (the plan let through before, shifted), ``"fallback"`` or
    ``"manoeuvre:<name>"``."""
    check: SafetyCheck
    """The check of the candidate."""
    planned_wheels_mps: np.ndarray | None = None
    """(H, 2) the sequence that was let through, when known."""


class SafetyFilter(WayOutSearch, QuickScreen):
    """Checks candidate wheel speeds against the predicted obstacles; see the package text.

    Parameters
    ----------
    robot, sample_time_s, horizon, margin_m, sigmas, substeps
        As :class:`~casadi_gpc.safety.check.TrajectoryCheck`.
    fallback : object with ``decide(observation) -> ControlDecision``, optional
        The planner to hand over to (the GPC). If it has ``observe(observation)``, the
        filter calls it on every sample it does not hand over, so it stays in step.
    trust_planner_s : float, optional
        The planner's answer is taken when it keeps the margin at least this long, even if
        it fails the check later in the horizon (it replans at every sample, and late in the
        horizon the forecast's uncertainty has grown). Default: the larger of 3 s and two
        intervals, at most the horizon.
    trust_rollout_s : float, optional
        A one-command controller's roll-out (:meth:`filter`'s ``plan_on_demand``) passes when
        it keeps the margin at least this long; a pass that fails later in the horizon is
        counted in ``rollout_trusted``. None (the default): the whole horizon.
        :data:`ROLLOUT_TRUST_S` is the measured setting behind the planner on standby.
    safer_alternatives : bool
        A candidate that passes on ``trust_s`` alone (it keeps the margin that long, not over
        the horizon) gives way to the first of the controller's alternatives that keeps it
        over the horizon (:meth:`_safe_alternative`). Off by default;
        :data:`SAFER_ALTERNATIVES` says where it is on.
    """
    def __init__(self, robot: RobotParams, sample_time_s: float, horizon: int, margin_m: float = 0.05,
                 sigmas: float = 2.0, substeps: int = 4, fallback=None, trust_planner_s: float | None = None,
                 trust_rollout_s: float | None = None, safer_alternatives: bool = False, search: bool = False,
                 search_two_phase: bool = False, robust_drive_in: bool = False, search_near_walls: bool = False,
                 walls_margins: tuple[float, float] | None = None, robust_drive_ties: bool = False):
        super().__init__(robot, sample_time_s, horizon, margin_m, sigmas, substeps)
        if fallback is not None and not callable(getattr(fallback, "decide", None)):
            raise TypeError("fallback must have a decide(observation) method")
        self.fallback = fallback
        if trust_planner_s is None:
            trust_planner_s = min(self.horizon * self.sample_time_s, max(3.0, 2 * self.sample_time_s))
        for name, value in (("trust_planner_s", trust_planner_s), ("trust_rollout_s", trust_rollout_s)):
            if value is not None and not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and not negative, got {value}")
        self.trust_planner_s = float(trust_planner_s)
        self.trust_rollout_s = None if trust_rollout_s is None else float(trust_rollout_s)
        self.safer_alternatives = bool(safer_alternatives)
        self.search_way_out = bool(search)  # TrajectoryCheck's: the searched way out, and the escapes
        self.search_two_phase = bool(search_two_phase)  # WayOutSearch's: a second target where none is safe
        # with search_near_walls the two above are set at each check from these: on only where
        # the check is handed a wall (CheckSettings.search_near_walls)
        self.search_near_walls = bool(search_near_walls)
        self._search_setting = (self.search_way_out, self.search_two_phase)
        self.robust_drive_in = bool(robust_drive_in)  # Clearances': a drive-in judged against the uncertain discs too
        self.robust_drive_ties = bool(robust_drive_ties)  # Clearances': that judgement as a tie-break
        # with walls_margins the margin and sigmas are set at each check: these where the check is
        # handed a wall, the open ones elsewhere (CheckSettings.walls_margin_m)
        if walls_margins is not None and not all(math.isfinite(v) and v >= 0 for v in walls_margins):
            raise ValueError(f"walls_margins must be finite and not negative, got {walls_margins}")
        self._margins = (self.margin_m, self.sigmas)
        self._walls_margins = None if walls_margins is None else tuple(float(v) for v in walls_margins)
        self.reset()

    def reset(self) -> None:
        self.counters = {"checks": 0, "interventions": 0, "fallback_used": 0, "fallback_failed": 0,
                         "fallback_overruled": 0, "rollouts": 0, "rollout_passed": 0, "rollout_trusted": 0,
                         "alternative_used": 0, "alternative_safer": 0, "manoeuvres": 0, "no_safer_option": 0,
                         "candidate_limited": 0, "non_finite_candidate": 0, "unestimated_tracks": 0,
                         "searched": 0, "two_phase_searched": 0, "two_phase_taken": 0, "two_phase_safe": 0}
        if self.fallback is not None and hasattr(self.fallback, "reset"):
            self.fallback.reset()
    # --- the filter ----------------------------------------------------------------------
    def filter(self, observation: Observation, wheels, forecasts=(), statics=None, poses=None,
               alternatives=(), trust_s: float | None = None, previous=None, plan_on_demand=None,
               walls=None) -> SafetyVerdict:
        """Let the candidate ``wheels`` (``(2,)``, or its own plan ``(H, 2)``) through, or
        replace it (see :meth:`check`).

        ``forecasts`` are the obstacle forecasts the candidate was made with (steps 1..H):
        objects with the fields of :class:`~casadi_gpc.types.ObstacleForecast`
        (``obstacle_id``, ``radius_m``, ``means_m``, ``covs_m2``), such as the policy's
        track estimates; ``statics`` default to the observation's. ``poses`` (optional,
        ``(H, 3)``): the robot's poses after each step of the plan ``wheels`` from the
        observed state, as :func:`~casadi_gpc.robot.robot_step_float` gives them (the
        network's own roll-out), so that a plan the limits leave unchanged is not rolled
        out a second time. The fallback planner, if any, sees ``observation`` either way.
        ``alternatives``: other ``(H, 2)`` plans of the controller, best first, tried before
        the fallback planner and the manoeuvres when the candidate fails. ``trust_s``: for a
        planner that replans at every sample, a candidate (or alternative) whose check keeps
        the margin at least this long passes, as the fallback planner's answer does with
        ``trust_planner_s`` (None: the whole horizon, the rule for anything else); with
        ``safer_alternatives``, unless one of its ``alternatives`` keeps the margin over the
        whole horizon, which is then taken instead (:meth:`_safe_alternative`).
        ``previous``: the ``(H, 2)`` plan let through at the previous sample, shifted by one
        step: tried after the alternatives, as one more of them (source ``previous_plan``,
        counted in ``previous_plan_used`` and ``alternative_used``).
        ``plan_on_demand``: for a command without a plan, a callable giving the controller's
        own continuation, ``(plan (H, 2) whose first row is the command, poses (H, 3))`` or
        None (a one-command network's roll-out, :meth:`nn_export.OnnxPolicy.rollout`). It is
        asked for only when the command alone fails the check, and judged as a plan: if it
        keeps the margin over the whole horizon, or for the filter's ``trust_rollout_s``
        when that is set, the command goes through (counted in ``rollouts`` and
        ``rollout_passed``, the passes on trust alone also in ``rollout_trusted``; the
        check's continuation reads ``roll-out``), else the command is replaced as usual.
        (Trusted for 3 s behind the manoeuvres alone, roll-outs let walkers close in: the
        shipped crowd network collided in 2.5 % of 200 crossings among 10 walkers; behind
        the planner on standby, 4.5 s collided in none of 2 600: :data:`ROLLOUT_TRUST_S`;
        docs/nn-crowds.md, "The network's roll-out as its plan").
        ``walls``: the wall segments every option is judged against (``(nw, 2)`` complex
        ends, :func:`~casadi_gpc.safety.walls.wall_segments_within`), as the static obstacles.
        """
        self._screen_memo = None
        try:
            return self._filter(observation, wheels, forecasts, statics, poses, alternatives, trust_s, previous,
                                plan_on_demand, walls)
        finally:
            self._screen_memo = None

    def _filter(self, observation, wheels, forecasts, statics, poses, alternatives, trust_s, previous,
                plan_on_demand, walls) -> SafetyVerdict:
        """:meth:`filter`'s body."""
        near = walls is not None and len(walls) > 0  # the settings that switch by walls
        if self.search_near_walls:
            self.search_way_out, self.search_two_phase = (near and v for v in self._search_setting)
        if self._walls_margins is not None:
            self.margin_m, self.sigmas = self._walls_margins if near else self._margins
            if near:
                self.counters["walls_margin_checks"] = self.counters.get("walls_margin_checks", 0) + 1
        statics = observation.static if statics is None else statics
        r = observation.robot
        self.counters["checks"] += 1
        for f in forecasts:
            if not getattr(f, "initialised", True):
                self.counters["unestimated_tracks"] += 1  # checked as the planner plans with it
        quick = self._quick(r, wheels, forecasts, statics, poses, walls)
        if quick is not None:
            check, cmd, plan, limited = quick
            if limited:
                self.counters["candidate_limited"] += 1
            if self.fallback is not None and hasattr(self.fallback, "observe"):
                self.fallback.observe(observation)
            return SafetyVerdict(cmd[0], cmd[1], False, "", "candidate", check, plan)
        state = np.array([r.x_m, r.y_m, r.heading_rad, r.v_right_mps, r.v_left_mps], dtype=float)
        obstacles = self._screened_obstacles(forecasts, statics, walls)  # the screen's arrays, when it made them
        if obstacles is None:
            obstacles = self.obstacle_tracks(forecasts, statics, walls)
        cmd, plan, limited = self._as_candidate(state, wheels)
        if cmd is None:
            self.counters["non_finite_candidate"] += 1
            check = SafetyCheck(False, -math.inf, -math.inf, 0.0, "", "non-finite candidate", 0.0)
            return self._intervene(observation, state, obstacles, check, None, alternatives, trust_s, previous)
        if limited:
            # the simulator (and the robot) would clip it: what is checked is what would happen
            self.counters["candidate_limited"] += 1
        check = self._assess(state, cmd, plan, obstacles, trust_s)
        passed = _passes(check, trust_s)
        if not passed and plan is None and plan_on_demand is not None:
            own = self._judge_rollout(r, state, plan_on_demand, forecasts, statics, obstacles, walls)
            if own is not None:
                (check, cmd, plan), passed = own, True
        if passed and not check.safe and alternatives and self.safer_alternatives:
            safer = self._safe_alternative(state, obstacles, alternatives, check)
            if safer is not None:
                return safer
        if passed:
            if self.fallback is not None and hasattr(self.fallback, "observe"):
                self.fallback.observe(observation)
            return SafetyVerdict(float(cmd[0]), float(cmd[1]), False, "", "candidate", check, plan)
        return self._intervene(observation, state, obstacles, check, cmd, alternatives, trust_s, previous)

    def _safe_alternative(self, state, obstacles, alternatives, check: SafetyCheck) -> SafetyVerdict | None:
        """The first of the controller's alternatives that keeps the margin over the whole
        horizon, as the verdict (an intervention, counted ``alternative_safer``; not a
        fallback: the controller's own plan), else None. Asked for when the candidate
        passes on trust alone, predicted to lose the margin later in the horizon (``check``
        is its). The planner's plans are trusted for 3 s because a violation far ahead is
        mostly the forecast's grown uncertainty; but where the planner itself has a plan that
        keeps the margin all the way, that one is taken. On navground's Antipodal scene
        (seeds 1-200) the GPC sped into the centre on a trusted plan whose violation, 5.6 s
        ahead, came true: one collision; with this rule none (docs/peers.md)."""
        options = _as_options(alternatives)
        for source, name, acmd, aplan, achk in self._checked(state, obstacles, options, None):
            if achk.safe:
                self.counters["interventions"] += 1
                self.counters["alternative_safer"] += 1
                return SafetyVerdict(float(acmd[0]), float(acmd[1]), True,
                                     f"safety: the candidate keeps the margin only {check.kept_s:.1f} s; {name} "
                                     f"keeps it over the horizon", source,
                                     check, aplan)  # the candidate's check, as every intervention reports
        return None

    def _checked(self, state, obstacles, options, trust_s: float | None):
        """Each option ``(source, name, wheels)`` whose wheels are finite, checked in turn (as
        the robot would follow them, for ``trust_s``): ``(source, name, command, plan, check)``."""
        for source, name, w in options:
            acmd, aplan, _ = self._as_candidate(state, np.asarray(w, dtype=float))
            if acmd is not None:
                yield source, name, acmd, aplan, self._assess(state, acmd, aplan, obstacles, trust_s)

    def _judge_rollout(self, robot, state, plan_on_demand, forecasts, statics, obstacles, walls=None):
        """``(check, command, plan)`` when the controller's own continuation passes as a plan
        (:meth:`filter`'s ``plan_on_demand``), else None."""
        got = plan_on_demand()
        if got is None:
            return None
        self.counters["rollouts"] += 1
        wheels, poses = got
        quick = self._quick(robot, wheels, forecasts, statics, poses, walls)
        if quick is not None:
            check, cmd, plan, _ = quick
        else:
            cmd, plan, _ = self._as_candidate(state, wheels)
            if cmd is None:
                return None
            trust = self.trust_rollout_s
            check = self._assess(state, cmd, plan, obstacles, trust)
            if not _passes(check, trust):  # the whole horizon, or the trusted time (see filter)
                return None
            if not check.safe:
                self.counters["rollout_trusted"] += 1
        self.counters["rollout_passed"] += 1
        return replace(check, continuation="roll-out"), cmd, plan

    def _intervene(self, observation, state, obstacles, check: SafetyCheck, cmd, alternatives=(),
                   trust_s: float | None = None, previous=None) -> SafetyVerdict:
        """The candidate failed the check: what replaces it (:meth:`_replacement`), counted in
        ``interventions`` when it is not the candidate itself. (Until 2026-12-02 every failed check
        counted, the candidate kept as the best of bad options too, ``no_safer_option``: decisions
        the layer did not change, against CONTRACT.md's "decisions changed by the safety check
        layer"; 7 of the GPC's 12 on four replayed UCY cases, found by an audit.)"""
        verdict = self._replacement(observation, state, obstacles, check, cmd, alternatives, trust_s, previous)
        if verdict.source != "candidate":
            self.counters["interventions"] += 1
        return verdict

    def _replacement(self, observation, state, obstacles, check: SafetyCheck, cmd, alternatives=(),
                     trust_s: float | None = None, previous=None) -> SafetyVerdict:
        if math.isfinite(check.min_clearance_m):
            why = (f"safety: {check.obstacle} predicted clearance {check.min_clearance_m:.2f} m at "
                   f"+{check.time_s:.1f} s (margin {self.margin_m:.2f} m)")
        else:
            why = f"safety: {check.continuation}"
        # 1. the controller's own alternatives, best first, then its previous plan shifted: the
        # first that passes the check; else the best of them competes with the candidate below
        options = _as_options(alternatives)
        if previous is not None:
            options.append(("previous_plan", "the previous plan, shifted", previous))
        keep_cmd, keep_plan, keep_check, keep_source, kept = cmd, None, check, "candidate", "candidate kept"
        for source, name, acmd, aplan, achk in self._checked(state, obstacles, options, trust_s):
            if _passes(achk, trust_s):
                self.counters["alternative_used"] += 1
                if source == "previous_plan":
                    self.counters["previous_plan_used"] = self.counters.get("previous_plan_used", 0) + 1
                return SafetyVerdict(float(acmd[0]), float(acmd[1]), True, why + f"; {name}", source, check, aplan)
            if keep_cmd is None or self._better(achk, keep_check):
                keep_cmd, keep_plan, keep_check, keep_source, kept = acmd, aplan, achk, source, f"{name} kept"
        if self.fallback is not None:
            dec: ControlDecision = self.fallback.decide(observation)
            fcmd = np.array([dec.v_right_mps, dec.v_left_mps], dtype=float)
            if not dec.fallback and np.all(np.isfinite(fcmd)):
                plan = dec.planned_wheels_mps
                pcmd, pplan, _ = self._as_candidate(state, fcmd if plan is None else np.asarray(plan, float))
                pcheck = self._assess(state, pcmd, pplan, obstacles) if pcmd is not None else None
                if pcheck is not None and (pcheck.safe or pcheck.kept_s >= self.trust_planner_s - 1e-9):
                    self.counters["fallback_used"] += 1
                    return SafetyVerdict(float(pcmd[0]), float(pcmd[1]), True, why + "; fallback planner",
                                         "fallback", check, pplan)
                # the planner's answer fails the same check (it was handed a late situation, or
                # its soft margin gave way): take it only if neither a manoeuvre nor the
                # candidate itself does better
                name, mw, mc = self._way_out(state, obstacles, cmd)
                if pcheck is not None and not self._better(mc, pcheck) and (
                        keep_cmd is None or not self._better(keep_check, pcheck)):
                    self.counters["fallback_used"] += 1
                    return SafetyVerdict(float(pcmd[0]), float(pcmd[1]), True,
                                         why + "; fallback planner (no manoeuvre does better)", "fallback", check,
                                         pplan)
                self.counters["fallback_overruled"] += 1
                if keep_cmd is not None and not self._better(mc, keep_check):
                    # e.g. a track seen once, whose unknown motion makes every option fail far
                    # ahead: the candidate keeps the margin longest, so it stays
                    self.counters["no_safer_option"] += 1
                    return SafetyVerdict(float(keep_cmd[0]), float(keep_cmd[1]), True,
                                         why + f"; fallback planner's answer fails the check, no manoeuvre does "
                                         f"better: {kept}", keep_source, check, keep_plan)
                self.counters["manoeuvres"] += 1
                return SafetyVerdict(float(mw[0, 0]), float(mw[0, 1]), True,
                                     why + f"; fallback planner's answer fails the check, manoeuvre {name} "
                                     f"(clearance {mc.min_clearance_m:.2f} m, margin kept {mc.kept_s:.1f} s)",
                                     f"manoeuvre:{name}", check, mw)
            self.counters["fallback_failed"] += 1
            why += f"; fallback planner failed ({dec.reason})"
        name, mw, mc = self._way_out(state, obstacles, cmd)
        if keep_cmd is not None and not self._better(mc, keep_check):
            # nothing in the set does better than the candidate: keep it, and say so
            self.counters["no_safer_option"] += 1
            return SafetyVerdict(float(keep_cmd[0]), float(keep_cmd[1]), True, why + f"; no safer manoeuvre, {kept}",
                                 keep_source, check, keep_plan)
        self.counters["manoeuvres"] += 1
        return SafetyVerdict(float(mw[0, 0]), float(mw[0, 1]), True,
                             why + f"; manoeuvre {name} (clearance {mc.min_clearance_m:.2f} m, margin kept "
                             f"{mc.kept_s:.1f} s)", f"manoeuvre:{name}", check, mw)


    def _way_out(self, state, obstacles, cmd):
        """The check's own way out when nothing of the controller's passes: the searched one
        nearest the candidate's command (``search``, counted ``searched``), else the best
        manoeuvre."""
        if not self.search_way_out:
            return self.best_manoeuvre(state, obstacles)
        self.counters["searched"] += 1
        return self.search(state, obstacles, (0.0, 0.0) if cmd is None else cmd)


def _as_options(alternatives) -> list:
    """The controller's alternatives as options ``(source, name, wheels)``, best first."""
    return [(f"alternative:{i}", f"the controller's alternative {i}", w) for i, w in enumerate(alternatives, 1)]


def _passes(check: SafetyCheck, trust_s: float | None) -> bool:
    """Safe over the whole horizon, or, with ``trust_s``, for at least that long."""
    return check.safe or (trust_s is not None and check.kept_s >= trust_s - 1e-9)
