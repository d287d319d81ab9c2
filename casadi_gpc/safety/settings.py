"""What the check layer trusts from a controller, for how long, and what it falls back on:
one frozen settings object (numpy only).

Each controller declares its :class:`CheckSettings` next to its name in the one controller
registry (``gpcnav.controllers``); :class:`~casadi_gpc.safety.Shield` takes the controller,
the robot and these settings, so no caller chooses the check's flags by the kind of
controller it holds.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..finite import finite_real

__all__ = ["CheckSettings", "FALLBACKS"]

FALLBACKS = ("manoeuvres", "planner")
"""What the check hands over to when the controller's answer and its alternatives fail:
``manoeuvres``, the check's own fixed set (brake, swerve, slow turns, reverse, dash;
numpy only, what a robot without CasADi runs); ``planner``, the GPC kept on standby
(:class:`~casadi_gpc.safety.StandbyPlanner`), then the manoeuvres."""


@dataclass(frozen=True)
class CheckSettings:
    """The check layer's settings for one controller (docs/faults.md has the measured cost).

    Attributes
    ----------
    trust_plans : bool
        The controller is a planner that replans every sample (the GPC, a plan network): its
        plan, or one of its alternatives, passes when it keeps the margin for
        :attr:`trust_planner_s`; a violation later in the horizon, where the forecast's
        uncertainty has grown, is left to its next plans. False: the whole horizon counts.
    trust_planner_s : float or None
        How long a trusted plan (and the standby planner's answer) must keep the margin, s;
        None: 3 s, at least two samples and at most the horizon
        (:class:`~casadi_gpc.safety.SafetyFilter`).
    safer_alternatives : bool
        With :attr:`trust_plans`: a plan that passes on the trust time alone gives way to the
        first of the controller's alternatives that keeps the margin over the whole horizon
        (an intervention, not a fallback; counted ``shield_alternative_safer``).
        :data:`~casadi_gpc.safety.SAFER_ALTERNATIVES` says for which preset it was measured
        better.
    previous_plan : bool
        Keep the plan let through at each sample, shifted by one step, and offer it after the
        controller's own alternatives when its answer fails (the safe candidate of Hose et
        al.'s safety-augmented approximate MPC, for a controller that outputs whole plans).
        Taken, it is the controller's answer (not a fallback), with source ``previous_plan``,
        counted in ``shield_previous_plan_used`` (and, as every alternative, in
        ``shield_alternative_used``).
    rollouts : bool
        For a controller that answers one command and can roll itself forward (a
        ``rollout()`` method): when the command alone fails, its roll-out is judged as its
        plan before the check steps in (counted ``shield_rollouts``, ``shield_rollout_passed``;
        the plan let through is in the decision's ``info["rollout_wheels_mps"]``).
    trust_rollout_s : float or None
        With :attr:`rollouts`: a roll-out that keeps the margin this long passes (counted
        ``shield_rollout_trusted``); None: the whole horizon.
        :data:`~casadi_gpc.safety.ROLLOUT_TRUST_S` is the measured setting behind the
        standby planner.
    search : bool
        The check's own way out is searched (:meth:`~casadi_gpc.safety.search.WayOutSearch.search`:
        a grid of held wheel-speed targets beside the fixed manoeuvres, the safe one nearest
        the controller's command) instead of the best fixed manoeuvre (counted
        ``shield_searched``).
    search_two_phase : bool
        With :attr:`search`, when no searched sequence keeps the margin over the horizon: the
        best few of them are tried again with a second target after 1 s (back off, then go
        round; brake, then turn: :mod:`casadi_gpc.safety.search`), and one of those is taken when it keeps the
        margin, or when it is better by the check's order (counted ``shield_two_phase_searched``,
        ``shield_two_phase_taken``, and ``shield_two_phase_safe`` where it keeps the margin).
    search_near_walls : bool
        With :attr:`search`: the search (and :attr:`search_two_phase`) applies only at the
        decisions where a wall is within the check's reach (the segments the shield hands the
        check: the robot's top speed over the horizon, its radius and a metre beyond);
        elsewhere the way out is the best fixed manoeuvre and a command's escapes are the
        manoeuvres alone, as without :attr:`search`. Scenes without walls are unchanged
        decision for decision (docs/data/buildings/walls_search/).
    walls_margin_m, walls_sigmas : float or None
        Near walls (at the decisions where the shield hands the check a wall segment within
        its reach), the margin and the sigmas in place of :attr:`margin_m` and
        :attr:`sigmas` (counted ``shield_walls_margin_checks``); both or neither. The planner's
        own near-walls margin is :attr:`casadi_gpc.config.PlannerConfig.walls_margin_m`.
        None (the default): one margin everywhere.
    robust_drive_in : bool
        Where every option loses the margin and the check ranks them by how late each drives
        into what it touches: moving towards a person inside their disc inflated by the
        forecast's uncertainty counts as driving into them, as inside their expected disc does
        (walls and static obstacles, known exactly, as before). Off by default
        (docs/data/deploy/robust_drive_in/).
    robust_drive_ties : bool
        The same judgement as a tie-break only: among options that lose the margin and are
        equal on the first two keys (how late they drive into an expected disc or a wall, how
        long they stay clear of the expected discs), the one that moves towards a person
        inside their uncertain disc later is taken. Off by default
        (docs/data/pedestrians/robust_ties/).
    fallback : str
        One of :data:`FALLBACKS`.
    margin_m : float
        The clearance a checked sequence must keep from every inflated obstacle disc, m.
    sigmas : float
        How many standard deviations of the predicted position inflate a moving obstacle.
    substeps : int
        Sub-samples of every interval at which the clearance is measured (the closest
        approach between them is exact).
    horizon : int or None
        Intervals checked; None: the controller's own horizon, or 6 s of its samples.
    """

    trust_plans: bool = False
    trust_planner_s: float | None = None
    safer_alternatives: bool = False
    previous_plan: bool = False
    rollouts: bool = False
    trust_rollout_s: float | None = None
    search: bool = False
    search_two_phase: bool = False
    search_near_walls: bool = False
    walls_margin_m: float | None = None
    walls_sigmas: float | None = None
    robust_drive_in: bool = False
    robust_drive_ties: bool = False
    fallback: str = "manoeuvres"
    margin_m: float = 0.05
    sigmas: float = 2.0
    substeps: int = 4
    horizon: int | None = None

    def __post_init__(self):
        if self.fallback not in FALLBACKS:
            raise ValueError(f"fallback must be one of {', '.join(FALLBACKS)}, got {self.fallback!r}")
        for name in ("trust_planner_s", "trust_rollout_s"):
            value = getattr(self, name)
            if value is not None and not (finite_real(value) and value >= 0):
                raise ValueError(f"{name} must be finite and not negative, got {value!r}")
        if self.search_two_phase and not self.search:
            raise ValueError("search_two_phase needs search (it extends the searched way out)")
        if self.search_near_walls and not self.search:
            raise ValueError("search_near_walls needs search (it says where the search applies)")
        if (self.walls_margin_m is None) != (self.walls_sigmas is None):
            raise ValueError("walls_margin_m and walls_sigmas go together (both set, or neither)")
        for name in ("walls_margin_m", "walls_sigmas"):
            value = getattr(self, name)
            if value is not None and not (finite_real(value) and value >= 0):
                raise ValueError(f"{name} must be finite and not negative, got {value!r}")
        if not (finite_real(self.margin_m) and self.margin_m >= 0):
            raise ValueError(f"margin_m must be finite and not negative, got {self.margin_m!r}")
        if not (finite_real(self.sigmas) and self.sigmas >= 0):
            raise ValueError(f"sigmas must be finite and not negative, got {self.sigmas!r}")
        # (NaN and 2.5 passed here, and failed only when the check was built, NaN without the field's name)
        if not (_whole(self.substeps) and self.substeps >= 1):
            raise ValueError(f"substeps must be a whole number, at least 1, got {self.substeps!r}")
        if self.horizon is not None and not (_whole(self.horizon) and self.horizon >= 1):
            raise ValueError(f"horizon must be a whole number, at least 1, got {self.horizon!r}")
        if self.safer_alternatives and not self.trust_plans:
            raise ValueError("safer_alternatives applies to trusted plans: set trust_plans too")
        if self.trust_rollout_s is not None and not self.rollouts:
            raise ValueError("trust_rollout_s applies to roll-outs: set rollouts too")


def _whole(value) -> bool:
    """A whole number (4, np.int64(4), 4.0), not a bool, NaN or infinity."""
    return finite_real(value) and value == int(value)
