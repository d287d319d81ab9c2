"""The exact check of a wheel-speed sequence: the roll-out with the one robot model,
sub-sampled inside every interval, the obstacles at the same instants, the clearances with
the closest approach on every chord, a roll-out-free lower bound, and the verdict
(:class:`SafetyCheck`) on a candidate: its own plan, or the command followed by the best
way out of :data:`MANOEUVRES` (numpy and the compiled distances; see :mod:`casadi_gpc.safety`)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from math import isfinite

import numpy as np

from ..robot import RobotParams, followed_plan
from .clearances import Clearances
from .distances import approach
from .obstacles import Obstacles, forecast_arrays, forecast_covariances, shared_batch
from .ranking import TIE_M, best_unsafe_index, pick_index, within_limits_floats

__all__ = ["MANOEUVRES", "SEARCH_SPEEDS", "SEARCH_TURNS", "SafetyCheck", "TrajectoryCheck", "Obstacles", "forecast_covariances", "forecast_arrays",
           "shared_batch"]

MANOEUVRES: tuple[tuple[str, float, float], ...] = (
    ("brake", 0.0, 0.0),
    ("swerve_right", -0.25, 0.25),
    ("swerve_left", 0.25, -0.25),
    ("slow_right", 0.0, 0.5),
    ("slow_left", 0.5, 0.0),
    ("reverse", -0.5, -0.5),
    ("reverse_right", -0.5, -0.2),
    ("reverse_left", -0.2, -0.5),
    ("dash", 1.0, 1.0),
)
"""(name, right, left) wheel-speed targets as fractions of the speed limit. The two swerves
are offsets added to the current mean wheel speed (at least a quarter of the limit), the
others are absolute targets. 'right'/'left' name the side the robot turns towards."""

SEARCH_SPEEDS = (-1.0, -0.75, -0.5, 0.0, 0.25, 0.5, 0.75, 1.0)
"""The searched way out (:meth:`~casadi_gpc.safety.search.WayOutSearch.search`): mean wheel-speed targets, as
fractions of the speed limit, backwards as far as forwards: the wheels' limits, not a
reversing speed picked below them (reversing at most half the limit, walkers at 0.5 m/s
caught a robot backing away from them: docs/nn-deploy.md, "Reversing at the wheels' limit") ..."""
SEARCH_TURNS = (-0.5, -0.25, -0.1, 0.0, 0.1, 0.25, 0.5)
"""... and half the difference of the two wheels' targets (positive turns left), the same
fractions; every pair of the two within the limits, each target approached at the
acceleration limit and held, beside :data:`MANOEUVRES`."""


@dataclass(slots=True)  # made for every check: slots, not frozen (a frozen init costs 5x)
class SafetyCheck:
    """The verdict on one wheel-speed sequence."""

    safe: bool
    min_clearance_m: float
    """Smallest inflated clearance over the horizon (``inf`` without obstacles); with
    ``continuation == "bound"`` a lower bound of it (see :meth:`SafetyFilter.bound`)."""
    current_clearance_m: float
    """Inflated clearance now, before the robot moves (a lower bound, as above)."""
    time_s: float
    """When the smallest clearance occurs, from now."""
    obstacle: str
    """Which obstacle: ``"moving <id>"`` or ``"static <index>"`` (empty without obstacles)."""
    continuation: str
    """What follows the command in the sequence judged: ``"plan"`` (the candidate's own),
    ``"then <manoeuvre>"`` (the best way out after one interval of the command),
    ``"bound"`` / ``"bound, then brake"`` (far enough from everything, the plan or the
    command then braking, that no roll-out was needed), or ``"roll-out"`` (the controller's
    own continuation, asked for when the command alone failed: ``SafetyFilter.filter``'s
    ``plan_on_demand``)."""
    kept_s: float = math.inf
    """How long from now the clearance stays at or above the margin (or, inside an obstacle's
    margin, at or above its own clearance now); the horizon when it always does."""
    exact: bool = True
    """False when a quick screen settled it: ``min_clearance_m`` is then a lower bound."""
    contact_s: float = math.inf
    """How long from now the sequence stays clear of the obstacles' expected discs (not
    inflated by their uncertainty: where the forecasts expect them, and the walls and static
    obstacles themselves), or, touching one now, does not close in further; the horizon when
    it always does. What ranks sequences that all lose the (inflated) margin
    (:meth:`TrajectoryCheck._better`)."""
    fixed_contact_s: float = math.inf
    """The same for the fixed obstacles alone (the walls and static discs): what ranks
    sequences that lose the margin and touch an expected disc equally soon, so that among ways
    out that all meet a person at once the robot does not also drive into a wall."""
    drives_in_s: float = math.inf
    """When the sequence first drives into an obstacle's expected disc or a wall (touching it
    and moving towards it faster than :data:`~casadi_gpc.safety.clearances.DRIVEN_MPS`), if
    that is sooner than the check's commitment time (:attr:`TrajectoryCheck.commit_s`); else
    that time (``inf`` for a sequence that keeps the margin). What ranks first among
    sequences that lose the margin: a contact the robot can no longer brake out of is better
    met standing or giving way than driving (:meth:`TrajectoryCheck._better`)."""
    uncertain_drives_in_s: float = math.inf
    """The same with a person's disc inflated by the forecast's uncertainty (the discs the margin
    is kept from) counted as touching them, when the check's ``robust_drive_ties`` is on (else
    :attr:`drives_in_s` again): what ranks sequences equal on :attr:`drives_in_s` and
    :attr:`contact_s`, so that among options that all miss the people where the forecasts expect
    them, the one that does not move towards anyone where they may be is taken
    (docs/data/pedestrians/robust_ties/)."""



class TrajectoryCheck(Clearances):
    """The exact check (see the module text); :class:`~casadi_gpc.safety.filter.SafetyFilter`
    adds the quick screen and the interventions.

    Parameters
    ----------
    robot : RobotParams
        Geometry and limits (radius, wheel base, speed and acceleration limits).
    sample_time_s : float
        T, the interval over which each wheel-speed pair is held.
    horizon : int
        H, the number of intervals checked (the forecasts must cover them).
    margin_m : float
        Smallest acceptable inflated clearance, m.
    sigmas : float
        k, how many predicted standard deviations inflate a moving obstacle.
    substeps : int
        Sub-samples per interval of the roll-out (closest approach exact between them).
    """

    def __init__(self, robot: RobotParams, sample_time_s: float, horizon: int, margin_m: float = 0.05,
                 sigmas: float = 2.0, substeps: int = 4):
        if not (math.isfinite(sample_time_s) and sample_time_s > 0):
            raise ValueError(f"sample_time_s must be positive, got {sample_time_s}")
        if int(horizon) != horizon or horizon < 1:
            raise ValueError(f"horizon must be a positive integer, got {horizon}")
        if int(substeps) != substeps or substeps < 1:
            raise ValueError(f"substeps must be a positive integer, got {substeps}")
        if not (math.isfinite(margin_m) and margin_m >= 0):
            raise ValueError(f"margin_m must be finite and not negative, got {margin_m}")
        if not (math.isfinite(sigmas) and sigmas >= 0):
            raise ValueError(f"sigmas must be finite and not negative, got {sigmas}")
        self.robot = robot
        self.sample_time_s = float(sample_time_s)
        self.horizon = int(horizon)
        self.margin_m = float(margin_m)
        self.sigmas = float(sigmas)
        self.substeps = int(substeps)
        S, T = self.substeps, self.sample_time_s
        self._tau = T * np.arange(1, S + 1) / S          # sub-sample times inside an interval
        self._frac = np.arange(1, S + 1) / S              # the same as fractions of T
        self._steps = np.arange(1, self.horizon + 1)
        # obstacle positions now and at steps 1..H from steps 1..H: now is the step back from
        # step 1 (the EKF's model moves an obstacle by a near-constant chord each step) ...
        H, N = self.horizon, self.horizon * S
        self._known = np.zeros((H, H + 1))
        self._known[:, 1:] = np.eye(H)
        self._known[0, 0] = 2.0 if H > 1 else 1.0
        if H > 1:
            self._known[1, 0] = -1.0
        # ... and at the sub-sample instants, linear between steps
        self._interp = np.zeros((H + 1, N + 1))
        self._interp[0, 0] = 1.0
        for k in range(H):
            self._interp[k, 1 + k * S:1 + (k + 1) * S] = 1.0 - self._frac
            self._interp[k + 1, 1 + k * S:1 + (k + 1) * S] = self._frac
        # path length bound of 'the command, then anything within the limits' after step 1
        self._full_reach = self.robot.max_wheel_speed_mps * T * np.arange(H)
        self._names = [m[0] for m in MANOEUVRES]
        self._then_names = ["then " + n for n in self._names]
        rev = MANOEUVRES[self._names.index("reverse")]
        self._reverse_target = (rev[1] * self.robot.max_wheel_speed_mps, rev[2] * self.robot.max_wheel_speed_mps)
        self._targets = np.array([m[1:] for m in MANOEUVRES], dtype=float)
        self._swerves = np.array([m[0].startswith("swerve") for m in MANOEUVRES])
        self._fixed_targets = self._targets * self.robot.max_wheel_speed_mps
        self._swerve_rows = self._swerves.astype(float)
        self._dv = self.robot.max_step_change_mps(T)
        grid = [(u + d, u - d) for u in SEARCH_SPEEDS for d in SEARCH_TURNS
                if abs(u + d) <= 1.0 and abs(u - d) <= 1.0 and (u >= 0.0 or abs(d) <= 0.25)]
        self._search_targets = np.array(grid, dtype=float) * self.robot.max_wheel_speed_mps
        self._no_swerves = np.zeros(len(grid))
        self._search_names = [f"search({0.5 * (r + l):+.2f},{0.5 * (r - l):+.2f})" for r, l in grid] + self._names
        self._then_search_names = ["then " + n for n in self._search_names]
        # grid targets that are also a fixed manoeuvre's (not a swerve; the same float bits):
        # approached from the same speeds they are the same sequences, bit for bit, so their
        # numbers are the manoeuvre's, not rolled out and measured a second time. _grid_own: the
        # grid rows rolled out; _set_rows: the set's rows that are (those, then the manoeuvres);
        # _set_order: the set's numbers (grid, then manoeuvres) from theirs
        twins = [next((k for k in range(len(MANOEUVRES)) if not self._swerves[k]
                       and self._fixed_targets[k].tobytes() == t.tobytes()), -1) for t in self._search_targets]
        own = [i for i, k in enumerate(twins) if k < 0]
        self._grid_own = np.array(own, dtype=np.int64)
        self._own_targets = np.ascontiguousarray(self._search_targets[self._grid_own])
        self._set_rows = np.array(own + [len(grid) + k for k in range(len(MANOEUVRES))], dtype=np.int64)
        self._set_order = np.array([own.index(i) if k < 0 else len(own) + k for i, k in enumerate(twins)]
                                   + [len(own) + k for k in range(len(MANOEUVRES))], dtype=np.int64)
        self.search_way_out = False
        """Whether the way out is searched (:meth:`search`) and a command's escapes are the
        searched grid and the manoeuvres, not the manoeuvres alone (set by the filter)."""
        # the wish's weight per step: the near steps count most (the next command is what is applied)
        self._search_weights = 1.0 / np.arange(1, self.horizon + 1)
        self.commit_s = T + self.robot.max_wheel_speed_mps / self.robot.max_wheel_accel_mps2
        """The commitment time: the command is held one interval, and from any speed the next
        decision can stop the robot within ``max_wheel_speed / max_wheel_accel`` after it. A
        contact the sequence drives into sooner than this is one no later decision can brake
        out of (passive safety: if a contact cannot be avoided, meet it standing or giving
        way); a later one is still the next decision's to avoid."""
        self._commit_chords = min(N, math.ceil(self.commit_s * S / T - 1e-9))


    # --- limits and obstacles (the roll-out and the clearances: :mod:`.clearances`) -------
    def limit(self, v0, wheels: np.ndarray) -> np.ndarray:
        """``wheels`` (..., H, 2) followed within the limits from the current speeds ``v0``,
        exactly as the simulator clips them (rate first, then speed)."""
        dv, vmax = self.robot.max_step_change_mps(self.sample_time_s), self.robot.max_wheel_speed_mps
        if wheels.ndim == 2:  # one sequence: plain floats beat numpy calls on pairs
            return followed_plan(v0[0], v0[1], wheels, dv, vmax)
        out = np.empty_like(wheels)
        v = np.broadcast_to(np.asarray(v0, dtype=float), wheels[..., 0, :].shape)
        for i in range(wheels.shape[-2]):
            v = np.minimum(np.maximum(np.minimum(np.maximum(wheels[..., i, :], v - dv), v + dv), -vmax), vmax)
            out[..., i, :] = v
        return out

    @property
    def _dv_tol(self) -> float:
        return self.robot.max_step_change_mps(self.sample_time_s) + 1e-9  # the limits' bounds, with their tolerance

    @property
    def _vmax_tol(self) -> float:
        return self.robot.max_wheel_speed_mps + 1e-9

    def obstacle_tracks(self, forecasts, statics, walls=None) -> "Obstacles":
        """The obstacles at the sample instants: positions now and at steps 1..H (complex
        x + iy, ``(n, H + 1)``) and the distance at which the robot touches each one over
        each interval ``(n, H)`` (radii plus k sigma at the end of the interval, m); and the
        wall segments ``walls`` (``(nw, 2)`` complex ends, :mod:`.walls`), touched at the
        robot's radius."""
        H = self.horizon
        nm, n = len(forecasts), len(forecasts) + len(statics)
        q = np.empty((n, H + 1), dtype=complex)
        touch = np.empty((n, H))
        if nm:
            try:
                m, c, w = forecast_arrays(forecasts)     # (n, H, 2), (n, H, 2, 2), (n, H)
            except ValueError:
                raise ValueError("obstacle forecasts of different lengths") from None
            if m.shape[1:] != (H, 2) or c.shape[1:] != (H, 2, 2):
                raise ValueError(f"obstacle forecasts must cover {H} steps with (H, 2) means and (H, 2, 2) "
                                 f"covariances, got {m.shape[1:]} and {c.shape[1:]}")
            q[:nm] = m.view(complex)[..., 0] @ self._known          # x + iy, without arithmetic
        radii = np.empty(n)
        if nm:
            radii[:nm] = np.array([f.radius_m for f in forecasts], dtype=float) + self.robot.radius_m
            touch[:nm] = self.sigmas * w + radii[:nm, None]
        for i, st in enumerate(statics):
            q[nm + i] = complex(st.position_m[0], st.position_m[1])
            touch[nm + i] = radii[nm + i] = st.radius_m + self.robot.radius_m
        return Obstacles(q, touch, tuple(forecasts), tuple(statics), self, radii, walls)

    def bound(self, state, cmd, plan, obstacles: "Obstacles") -> tuple[float, int, int]:
        """A lower bound of the clearance over the horizon that needs no roll-out: over
        interval k the robot is within its path length S_k of where it is now, and the
        obstacle within its chord of where it is at step k, so the clearance is at least
        ``|p_now - q_k| - S_k - |q_k - q_(k-1)| - touch_k``. S_k is the plan's path length,
        or, with a command alone, the command's interval then full speed (any way out).
        Returns the bound, the obstacle and the interval (0-based) where it is smallest."""
        T = self.sample_time_s
        if plan is not None:
            reach = np.add.accumulate(np.abs(plan[:, 0] + plan[:, 1])) * (0.5 * T)
        else:
            reach = abs(0.5 * float(cmd[0] + cmd[1])) * T + self._full_reach
        q, p0 = obstacles.q, complex(state[0], state[1])
        gap = (np.abs(q[:, 1:] - p0) - np.abs(q[:, 1:] - q[:, :-1])) - obstacles.touch
        low = gap - reach
        if len(obstacles.walls):
            low = np.concatenate([low, self.wall_bounds(p0, obstacles.walls, reach)])
        i = int(low.argmin())
        return float(low.flat[i]), i // self.horizon, i % self.horizon

    # --- candidates ----------------------------------------------------------------------
    def manoeuvres(self, v0, steps: int | None = None) -> tuple[list[str], np.ndarray]:
        """The fixed manoeuvres from wheel speeds ``v0``: names and (M, steps, 2) wheel
        speeds (``steps`` = H by default), each target approached at the acceleration limit
        and then held."""
        steps = self.horizon if steps is None else steps
        out = np.empty((len(self._names), steps, 2))
        self._approach(out, 0, v0, False)
        return self._names, out

    def _approach(self, out: np.ndarray, offset: int, v0, searched: bool) -> None:
        """Fill ``out[:, offset:]`` with the manoeuvres (or the searched grid's targets) from
        the wheel speeds ``v0``, each target approached at the acceleration limit and held
        (:func:`~casadi_gpc.safety.distances.approach`, compiled): the swerves keep the
        current mean speed (at least a quarter of the limit); between ``v0`` and the target,
        both within the limits, no speed clip is needed."""
        if searched:
            approach(out, offset, float(v0[0]), float(v0[1]), self._search_targets, self._no_swerves, False,
                     self.robot.max_wheel_speed_mps, self._dv)
        else:
            approach(out, offset, float(v0[0]), float(v0[1]), self._fixed_targets, self._swerve_rows, True,
                     self.robot.max_wheel_speed_mps, self._dv)

    def _escapes(self, cmd: np.ndarray, searched: bool = False, own_only: bool = False) -> np.ndarray:
        """(M, H, 2): ``cmd`` for one interval, then each manoeuvre from there (``searched``:
        each target of the searched grid instead; with :attr:`search_way_out` a command passes
        when some way out of the set the check itself would take, the grid and the manoeuvres,
        keeps the margin). ``own_only`` (with ``searched``): only the grid's rows that are not
        also a manoeuvre's (``_grid_own``; the same rows as ``_escapes(cmd, True)[_grid_own]``)."""
        if searched and own_only:
            W = np.empty((len(self._grid_own), self.horizon, 2))
            W[:, 0] = cmd
            approach(W, 1, float(cmd[0]), float(cmd[1]), self._own_targets, self._no_swerves[:len(self._grid_own)],
                     False, self.robot.max_wheel_speed_mps, self._dv)
            return W
        W = np.empty((len(self._search_targets) if searched else len(self._names), self.horizon, 2))
        W[:, 0] = cmd
        self._approach(W, 1, cmd, searched)
        return W

    def _searched(self, v0, steps: int) -> np.ndarray:
        """(K, steps, 2): each target of the searched grid approached from ``v0`` at the
        acceleration limit and held."""
        out = np.empty((len(self._search_targets), steps, 2))
        self._approach(out, 0, v0, True)
        return out

    def _as_candidate(self, state, wheels) -> tuple[np.ndarray | None, np.ndarray | None, bool]:
        """(command (2,), own plan (H, 2) or None, whether it had to be limited); None
        command when it is not finite."""
        w = wheels if isinstance(wheels, np.ndarray) and wheels.dtype == float else np.asarray(wheels, dtype=float)
        if w.shape == (2,):
            plan = None
        elif w.shape == (self.horizon, 2):
            plan = w
        else:
            raise ValueError(f"candidate wheel speeds must have shape (2,) or ({self.horizon}, 2), got {w.shape}")
        seq = w.reshape(-1, 2)
        flat = seq.tolist()  # plain floats: the same tests as numpy's, a tenth of the cost
        if not all(isfinite(a) and isfinite(b) for a, b in flat):
            return None, None, False
        limited = not within_limits_floats(float(state[3]), float(state[4]), flat, self._dv_tol, self._vmax_tol)
        if limited:
            seq = self.limit(state[3:5], seq)
        return seq[0].copy(), (seq if plan is not None else None), limited

    def _check_best(self, state, wheels, obstacles, labels: list[str]) -> SafetyCheck:
        """The check of the best sequence of ``wheels`` (M, H, 2) (:meth:`_better`'s order):
        one that keeps the margin over the horizon; else the one that stays longest clear of
        where the forecasts expect the obstacles (:attr:`SafetyCheck.contact_s`), then off the
        walls and static obstacles (:attr:`SafetyCheck.fixed_contact_s`), then keeps
        the margin longest from their discs inflated by the forecasts' uncertainty (a violation late in the horizon,
        where the forecasts are uncertain, is not as bad as one in the next second), then
        the one with the largest smallest clearance, then the first."""
        return self._pick(self.clearances(state, wheels, obstacles), obstacles, labels)

    def _pick(self, found: tuple, obstacles, labels: list[str]) -> SafetyCheck:
        """:meth:`_check_best` of :meth:`clearances`' answer ``found``."""
        i = pick_index(found[0], found[4], found[5], found[6], found[7], found[8], self.horizon * self.substeps,
                       self._commit_chords)  # compiled (ranking.py: the numpy form's index)
        return self._verdict(found, i, obstacles, labels[i])

    def _best_unsafe(self, found: tuple) -> int:
        """The index of the best of sequences that all lose the margin, by :meth:`_better`'s
        order: the latest to drive into a contact within the commitment time, then the longest
        clear of the expected discs, then (with ``robust_drive_ties``) the latest to move towards
        a person inside their uncertain disc within it, then the longest off the fixed obstacles,
        then the longest keeping the margin, then the largest smallest clearance, then the first."""
        return best_unsafe_index(found[0], found[4], found[5], found[6], found[7], found[8], self._commit_chords)

    def _verdict(self, found: tuple, i: int, obstacles, label: str) -> SafetyCheck:
        """The :class:`SafetyCheck` of the ``i``-th sequence of :meth:`clearances`' answer ``found``."""
        cmin, now, chord, which, kept, contact, fixed, drives, rdrives = found
        N, tau, commit = self.horizon * self.substeps, self.sample_time_s / self.substeps, self._commit_chords
        safe = bool(kept[i] == N)
        return SafetyCheck(safe, float(cmin[i]), float(now[i]), float(chord[i] + 1) * tau,
                           obstacles.label(int(which[i])), label, float(kept[i]) * tau,
                           contact_s=float(contact[i]) * tau, fixed_contact_s=float(fixed[i]) * tau,
                           drives_in_s=math.inf if safe else float(min(int(drives[i]), commit)) * tau,
                           uncertain_drives_in_s=math.inf if safe else float(min(int(rdrives[i]), commit)) * tau)

    @staticmethod
    def _better(a: SafetyCheck, b: SafetyCheck) -> bool:
        """Whether ``a`` is strictly better than ``b``: safe over one that is not; between
        two that lose the margin, the one that drives into a contact later, within the
        commitment time (:attr:`SafetyCheck.drives_in_s`: met standing or giving way, a contact
        is not the robot's doing, and a person who sees the robot can still avoid it), then
        the one that stays clear of the obstacles' expected discs
        longer (:attr:`SafetyCheck.contact_s`: the walls' and static obstacles' own, the
        movers' where the forecasts expect them), then the one that moves towards a person
        inside their uncertain disc later (:attr:`SafetyCheck.uncertain_drives_in_s`, the
        same as the first unless the check's ``robust_drive_ties`` is on), then the one that stays off the walls and
        static obstacles longer (:attr:`SafetyCheck.fixed_contact_s`), then the one that keeps
        the margin from their inflated discs longer (:attr:`SafetyCheck.kept_s`); then the
        larger smallest clearance.

        Ranked by the inflated discs alone (metres wide a few seconds ahead in a dense
        crowd), the check swapped the planner's plan for whichever manoeuvre lost the margin
        last: among 20 ORCA walkers, 6 collisions in 40 episodes against 2 for the planner
        alone. By the time to *touch*, not to lose the margin: by the margin, a dash into a
        corridor's wall 0.3 s on was taken (docs/pedestrians.md)."""
        if a.safe != b.safe:
            return a.safe
        if not a.safe and abs(a.drives_in_s - b.drives_in_s) > 1e-12:
            return a.drives_in_s > b.drives_in_s
        if not a.safe and abs(a.contact_s - b.contact_s) > 1e-12:
            return a.contact_s > b.contact_s
        if not a.safe and abs(a.uncertain_drives_in_s - b.uncertain_drives_in_s) > 1e-12:
            return a.uncertain_drives_in_s > b.uncertain_drives_in_s
        if not a.safe and abs(a.fixed_contact_s - b.fixed_contact_s) > 1e-12:
            return a.fixed_contact_s > b.fixed_contact_s
        return a.kept_s > b.kept_s + 1e-12 or (abs(a.kept_s - b.kept_s) <= 1e-12
                                               and a.min_clearance_m > b.min_clearance_m + TIE_M)

    def _assess(self, state, cmd, plan, obstacles, enough_s: float | None = None) -> SafetyCheck:
        """The check of a command (and its own plan, if any): its plan first; if that fails
        or there is none, the command followed by each manoeuvre (the best of them).
        ``enough_s``: a plan that keeps the margin this long is answer enough (a trusted
        planner's, :meth:`SafetyFilter.filter`'s ``trust_s``): the manoeuvres are not rolled out."""
        horizon_s = self.horizon * self.sample_time_s
        if not len(obstacles.q) and not len(obstacles.walls):
            return SafetyCheck(True, math.inf, math.inf, 0.0, "", "", horizon_s)
        lower, j, k = self.bound(state, cmd, plan, obstacles)
        if lower >= self.margin_m:
            # far from everything whatever follows: no roll-out needed
            return SafetyCheck(True, lower, lower, (k + 1) * self.sample_time_s, obstacles.label(j), "bound",
                               horizon_s)
        if plan is not None:
            plan_check = self._check_best(state, plan[None], obstacles, ["plan"])
            if plan_check.safe or (enough_s is not None and plan_check.kept_s >= enough_s - 1e-9):
                return plan_check
        way_out = self._way_out_after(state, cmd, obstacles)
        if plan is not None and self._better(plan_check, way_out):
            return plan_check
        return way_out

    def _way_out_after(self, state, cmd, obstacles) -> SafetyCheck:
        """The best way out after one interval of ``cmd`` (:meth:`_assess`), made once per
        command and state for the obstacles of one check (a command and its roll-out share it)."""
        key = (float(cmd[0]), float(cmd[1]), *map(float, state))
        way_out = obstacles.memo.get(key)
        if way_out is not None:
            return way_out
        man = self.clearances(state, self._escapes(cmd), obstacles)
        way_out = self._pick(man, obstacles, self._then_names)
        if self.search_way_out and not way_out.safe:
            # the fixed manoeuvres first (9 roll-outs); the searched grid (5 times as many) only
            # when none of them keeps the margin: the verdict is that of the whole set either way
            # (the best of the set is safe when any of it is), at a fifth of its cost when the
            # manoeuvres suffice. Each sequence's numbers are its own, so the grid's are joined
            # to the manoeuvres' already found, in the set's order (grid, then manoeuvres).
            # (the grid's rows that are manoeuvres too take the manoeuvres' numbers: _set_order)
            grid = self.clearances(state, self._escapes(cmd, True, own_only=True), obstacles)
            order = self._set_order
            searched = self._pick(tuple(np.concatenate(ab)[order] for ab in zip(grid, man)), obstacles,
                                  self._then_search_names)
            if self._better(searched, way_out):
                way_out = searched
        obstacles.memo[key] = way_out
        return way_out

    def check(self, state, wheels, forecasts=(), statics=(), walls=None) -> SafetyCheck:
        """The verdict on a candidate from ``state`` = (x, y, heading, v_right, v_left).

        ``wheels``: the command ``(2,)``, or the candidate's own plan ``(H, 2)`` whose first
        row is the command. It is safe when its plan keeps the clearance, or when after one
        interval of the command some manoeuvre of :data:`MANOEUVRES` does (there is still a
        way out). Sequences outside the limits are checked as the robot would follow them.
        """
        state = np.asarray(state, dtype=float)
        if state.shape != (5,) or not np.all(np.isfinite(state)):
            raise ValueError(f"state must be 5 finite numbers (x, y, heading, v_right, v_left), got {state}")
        cmd, plan, _ = self._as_candidate(state, wheels)
        if cmd is None:
            return SafetyCheck(False, -math.inf, -math.inf, 0.0, "", "non-finite candidate", 0.0)
        return self._assess(state, cmd, plan, self.obstacle_tracks(forecasts, statics, walls))

    def best_manoeuvre(self, state, obstacles) -> tuple[str, np.ndarray, SafetyCheck]:
        """The best manoeuvre from now (see :meth:`_check_best`): name, (H, 2) wheels and its check."""
        names, W = self.manoeuvres(np.asarray(state, float)[3:5])
        check = self._check_best(np.asarray(state, float), W, obstacles, names)
        i = names.index(check.continuation)
        return names[i], W[i], check
