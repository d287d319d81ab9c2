"""A safety filter around the network: check its wheel speeds against the predicted
obstacles and replace them when they come too close (numpy only).

A network that imitates an optimiser has no guarantee. Each sample, :class:`SafetyFilter`
rolls the candidate wheel-speed sequence out over the horizon with the one robot model
(:func:`casadi_gpc.robot.robot_step`, sub-sampled inside every interval like the
simulator's collision check), and measures the clearance to every obstacle disc:

    clearance(t) = |p_robot(t) - q_obstacle(t)| - r_robot - r_obstacle - k sigma(t)

where ``q`` is the EKF's predicted position (linearly interpolated between samples) and
``sigma`` the standard deviation of the predicted position along its worst direction
(the square root of the largest eigenvalue of the 2x2 covariance at the end of the
interval), so an uncertain obstacle is a larger disc. Static discs have ``sigma = 0``.
Between two sub-samples the robot and the obstacle move on straight chords and the
closest approach on each chord is computed exactly, so a fast pass between sub-samples is
not missed.

A candidate is the command for the next interval, optionally with the candidate's own plan
for the whole horizon (the network's pass-1 roll-out). It is **accepted** when its plan keeps
the smallest clearance over the horizon at or above ``margin_m``, or, failing that (or
without a plan), when after one interval of the command at least one manoeuvre of the fixed
set below still does: there is still a way out, checked against every obstacle over the
whole horizon. When the robot is already inside the margin (an obstacle first seen close
by), a sequence that makes the clearance no smaller than it is now also passes. Otherwise
the filter **intervenes**, in this order:

1. the fallback planner, if one was given (an object with ``decide(observation)``, usually
   the GPC kept on standby by :class:`StandbyPlanner`), unless its own answer is a
   fallback. Its answer is taken when it passes the same check or keeps the margin for at
   least ``trust_planner_s`` (default 3 s, at least two intervals: it replans at every
   sample, and a violation late in the horizon is mostly the forecast's grown
   uncertainty); else the best of it, the candidate and the best manoeuvre below (by the
   order below; counted ``fallback_overruled`` when it is not the planner's). (Overruling
   it on any violation made the robot back away from a fast head-on obstacle for 25
   samples in a row, each reverse keeping the margin a little longer than the GPC's swerve.)
2. else the best of a small fixed set of manoeuvres within the speed and acceleration
   limits (brake, swerve left/right, slow turns, reverse, dash ahead), each a constant
   wheel-speed target approached at the acceleration limit. Best means: the clearance stays
   above the margin for the longest time (a violation late in the horizon, where the
   forecast's uncertainty has grown, is not as bad as one in the next second), then the
   largest smallest clearance, then the earlier one in :data:`MANOEUVRES` (braking first).
   If none is better than the candidate itself, the candidate is kept and that is counted
   (``no_safer_option``).

A moving obstacle seen only once (``initialised`` false on the policy's track estimate:
speed and heading unknown) is checked as the planner plans with it
(:func:`casadi_gpc.ekf.planning_covariances`): standing where it was seen, with its next
step's uncertainty; each such check is counted (``unestimated_tracks``). The EKF's own
forecast grows that uncertainty without information, so that every option "fails" it some
seconds ahead; the next sample gives it a velocity and the full check.

Every check and every intervention is counted in :attr:`SafetyFilter.counters`.
``docs/faults.md`` documents the settings and the measured cost.
"""
from __future__ import annotations

import math
import operator
from dataclasses import dataclass

import numpy as np

from casadi_gpc.ekf import planning_covariances
from casadi_gpc.robot import RobotParams, RobotState, robot_step, robot_step_float
from casadi_gpc.types import ControlDecision, Observation, ObstacleForecast, StaticObstacle

__all__ = ["MANOEUVRES", "SafetyCheck", "SafetyVerdict", "SafetyFilter", "StandbyPlanner"]

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

_TIE_M = 1e-9  # manoeuvres whose clearances differ by less than this are a tie
_NOT_WORSE_M = 1e-6  # inside the margin, a candidate may lose this much clearance and pass


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
    ``"then <manoeuvre>"`` (the best way out after one interval of the command), or
    ``"bound"`` / ``"bound, then brake"`` (far enough from everything, the plan or the
    command then braking, that no roll-out was needed)."""
    kept_s: float = math.inf
    """How long from now the clearance stays at or above the margin (or, inside the margin,
    at or above the clearance now); the horizon when it always does."""
    exact: bool = True
    """False when a quick screen settled it: ``min_clearance_m`` is then a lower bound."""


@dataclass(slots=True)
class SafetyVerdict:
    """What the filter lets through."""

    v_right_mps: float
    v_left_mps: float
    intervened: bool
    reason: str
    """Why it intervened and what replaced the candidate (empty when accepted)."""
    source: str
    """``"candidate"``, ``"fallback"`` or ``"manoeuvre:<name>"``."""
    check: SafetyCheck
    """The check of the candidate."""
    planned_wheels_mps: np.ndarray | None = None
    """(H, 2) the sequence that was let through, when known."""


class SafetyFilter:
    """Checks candidate wheel speeds against the predicted obstacles; see the module text.

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
    fallback : object with ``decide(observation) -> ControlDecision``, optional
        The planner to hand over to (the GPC). If it has ``observe(observation)``, the
        filter calls it on every sample it does not hand over, so it stays in step.
    trust_planner_s : float, optional
        The planner's answer is taken when it keeps the margin at least this long, even if
        it fails the check later in the horizon (it replans at every sample, and late in the
        horizon the forecast's uncertainty has grown). Default: the larger of 3 s and two
        intervals, at most the horizon.
    """

    def __init__(self, robot: RobotParams, sample_time_s: float, horizon: int, margin_m: float = 0.05,
                 sigmas: float = 2.0, substeps: int = 4, fallback=None, trust_planner_s: float | None = None):
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
        if fallback is not None and not callable(getattr(fallback, "decide", None)):
            raise TypeError("fallback must have a decide(observation) method")
        self.robot = robot
        self.sample_time_s = float(sample_time_s)
        self.horizon = int(horizon)
        self.margin_m = float(margin_m)
        self.sigmas = float(sigmas)
        self.substeps = int(substeps)
        self.fallback = fallback
        if trust_planner_s is None:
            trust_planner_s = min(self.horizon * self.sample_time_s, max(3.0, 2 * self.sample_time_s))
        if not (math.isfinite(trust_planner_s) and trust_planner_s >= 0):
            raise ValueError(f"trust_planner_s must be finite and not negative, got {trust_planner_s}")
        self.trust_planner_s = float(trust_planner_s)
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
        self._swerve_rows = self._swerves[:, None].astype(float)
        self._reach = self.robot.max_step_change_mps(T) * self._steps[None, :, None]
        self._dv = self.robot.max_step_change_mps(T)
        self.reset()

    def reset(self) -> None:
        self.counters = {"checks": 0, "interventions": 0, "fallback_used": 0, "fallback_failed": 0,
                         "fallback_overruled": 0,
                         "manoeuvres": 0, "no_safer_option": 0, "candidate_limited": 0,
                         "non_finite_candidate": 0, "unestimated_tracks": 0}
        if self.fallback is not None and hasattr(self.fallback, "reset"):
            self.fallback.reset()

    # --- roll-out and clearances ---------------------------------------------------------
    # Written for speed: every step of the filter is a handful of whole-array operations
    # (numpy's per-call overhead, not the arithmetic, is what costs at these sizes).
    def limit(self, v0, wheels: np.ndarray) -> np.ndarray:
        """``wheels`` (..., H, 2) followed within the limits from the current speeds ``v0``,
        exactly as the simulator clips them (rate first, then speed)."""
        dv, vmax = self.robot.max_step_change_mps(self.sample_time_s), self.robot.max_wheel_speed_mps
        if wheels.ndim == 2:  # one sequence: plain floats beat numpy calls on pairs
            vr, vl = float(v0[0]), float(v0[1])
            rows = []
            for r, l in wheels.tolist():
                vr = min(max(min(max(r, vr - dv), vr + dv), -vmax), vmax)
                vl = min(max(min(max(l, vl - dv), vl + dv), -vmax), vmax)
                rows.append((vr, vl))
            return np.array(rows)
        out = np.empty_like(wheels)
        v = np.broadcast_to(np.asarray(v0, dtype=float), wheels[..., 0, :].shape)
        for i in range(wheels.shape[-2]):
            v = np.minimum(np.maximum(np.minimum(np.maximum(wheels[..., i, :], v - dv), v + dv), -vmax), vmax)
            out[..., i, :] = v
        return out

    def within_limits(self, v0, wheels: np.ndarray) -> bool:
        """Whether the (H, 2) sequence ``wheels`` already keeps the speed and rate limits."""
        dv, vmax = self.robot.max_step_change_mps(self.sample_time_s), self.robot.max_wheel_speed_mps
        tol = 1e-9
        if np.abs(wheels).max() > vmax + tol or np.abs(wheels[0] - v0).max() > dv + tol:
            return False
        return len(wheels) < 2 or bool(np.abs(wheels[1:] - wheels[:-1]).max() <= dv + tol)

    def rollout(self, state, wheels: np.ndarray) -> np.ndarray:
        """Robot positions at the sub-sample instants as complex numbers x + iy,
        ``(M, H * substeps + 1)``, the first column now. ``state`` = (x, y, heading, ...),
        ``wheels`` (M, H, 2)."""
        T, W = self.sample_time_s, self.robot.wheel_base_m
        vr, vl = wheels[..., 0], wheels[..., 1]
        # heading at the start of each interval: the model turns by (vr - vl) T / W per interval
        turn = (vr - vl) * (T / W)
        h0 = (state[2] - turn) + np.add.accumulate(turn, axis=-1)
        # one call of the model for every sub-sample of every interval, from a local origin
        dx, dy, _ = robot_step(np, 0.0, 0.0, h0[..., None], vr[..., None], vl[..., None], self._tau, W)
        d = dx + 1j * dy                                                      # (M, H, S)
        # interval start points: the cumulated full-interval displacements (last sub-sample)
        end = d[..., -1]
        start = (complex(state[0], state[1]) - end) + np.add.accumulate(end, axis=-1)
        M, N = wheels.shape[0], self.horizon * self.substeps
        p = np.empty((M, N + 1), dtype=complex)
        p[:, 0] = complex(state[0], state[1])
        p[:, 1:] = (start[..., None] + d).reshape(M, N)
        return p

    def obstacle_tracks(self, forecasts, statics) -> "_Obstacles":
        """The obstacles at the sample instants: positions now and at steps 1..H (complex
        x + iy, ``(n, H + 1)``) and the distance at which the robot touches each one over
        each interval ``(n, H)`` (radii plus k sigma at the end of the interval, m)."""
        H = self.horizon
        nm, n = len(forecasts), len(forecasts) + len(statics)
        q = np.empty((n, H + 1), dtype=complex)
        touch = np.empty((n, H))
        if nm:
            try:
                m = np.array([f.means_m for f in forecasts], dtype=float)     # (n, H, 2)
                c = np.array([_covs(f) for f in forecasts], dtype=float)     # (n, H, 2, 2)
            except ValueError:
                raise ValueError("obstacle forecasts of different lengths") from None
            if m.shape[1:] != (H, 2) or c.shape[1:] != (H, 2, 2):
                raise ValueError(f"obstacle forecasts must cover {H} steps with (H, 2) means and (H, 2, 2) "
                                 f"covariances, got {m.shape[1:]} and {c.shape[1:]}")
            q[:nm] = m.view(complex)[..., 0] @ self._known          # x + iy, without arithmetic
            a, b, d = c[..., 0, 0], c[..., 0, 1], c[..., 1, 1]
            lam = (a + d) * 0.5 + np.hypot((a - d) * 0.5, b)            # largest eigenvalue (n, H)
            radii = np.array([f.radius_m for f in forecasts], dtype=float)
            touch[:nm] = self.sigmas * np.sqrt(np.maximum(lam, 0.0)) + (radii[:, None] + self.robot.radius_m)
        for i, st in enumerate(statics):
            q[nm + i] = complex(st.position_m[0], st.position_m[1])
            touch[nm + i] = st.radius_m + self.robot.radius_m
        return _Obstacles(q, touch, tuple(forecasts), tuple(statics), self)

    def bound(self, state, cmd, plan, obstacles: "_Obstacles") -> tuple[float, int, int]:
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
        q = obstacles.q
        gap = (np.abs(q[:, 1:] - complex(state[0], state[1])) - np.abs(q[:, 1:] - q[:, :-1])) - obstacles.touch
        low = gap - reach
        i = int(low.argmin())
        return float(low.flat[i]), i // self.horizon, i % self.horizon

    def clearances(self, state, wheels: np.ndarray, obstacles: "_Obstacles") -> tuple[np.ndarray, np.ndarray,
                                                                                  np.ndarray, np.ndarray]:
        """For each sequence in ``wheels`` (M, H, 2): the smallest inflated clearance over the
        horizon, the clearance now, the chord index and the obstacle of the minimum, and how
        many chords pass before the clearance first falls below the threshold (the margin,
        or, inside it, the clearance now): H * substeps when it never does."""
        M, N = wheels.shape[0], self.horizon * self.substeps
        if not len(obstacles.q):
            inf = np.full(M, np.inf)
            return inf, inf, np.zeros(M, int), np.zeros(M, int), np.full(M, N)
        q, touch = obstacles.sub_samples()
        rel = self.rollout(state, wheels)[:, None, :] - q                   # (M, n, N+1) robot - obstacle
        r0 = rel[..., :-1]                                                  # chord starts
        u = rel[..., 1:] - r0                                               # chord directions
        # closest approach on each chord: the relative motion is linear between sub-samples;
        # Re(r0 conj(u)) is the dot product, |u|^2 = Re(u conj(u))
        cu = np.conj(u)
        s = (r0 * cu).real / ((u * cu).real + 1e-18)
        s = np.minimum(np.maximum(-s, 0.0), 1.0)
        gap = np.abs(r0 + s * u) - touch
        flat = gap.reshape(M, -1)
        k = flat.argmin(axis=1)
        cmin = flat[np.arange(M), k]
        now = (np.abs(rel[..., 0]) - touch[:, 0]).min(axis=1)
        threshold = np.minimum(self.margin_m, now - _NOT_WORSE_M)
        if M == 1 and cmin[0] >= threshold[0]:
            kept = np.full(1, N)  # never below: no need to find where
        else:
            below = gap.min(axis=1) < threshold[:, None]
            kept = np.where(below.any(axis=1), below.argmax(axis=1), N)
        return cmin, now, k % N, k // N, kept

    # --- candidates ----------------------------------------------------------------------
    def manoeuvres(self, v0, steps: int | None = None) -> tuple[list[str], np.ndarray]:
        """The fixed manoeuvres from wheel speeds ``v0``: names and (M, steps, 2) wheel
        speeds (``steps`` = H by default), each target approached at the acceleration limit
        and then held."""
        steps = self.horizon if steps is None else steps
        vmax = self.robot.max_wheel_speed_mps
        v0 = np.minimum(np.maximum(np.asarray(v0, dtype=float), -vmax), vmax)
        # the swerves keep the current mean speed (at least a quarter of the limit)
        tgt = self._fixed_targets + self._swerve_rows * max(0.5 * float(v0[0] + v0[1]), 0.25 * vmax)
        tgt = np.minimum(np.maximum(tgt, -vmax), vmax)                          # (M, 2)
        reach = self._reach[:, :steps]                                           # (1, steps, 1)
        # between v0 and the target, both within the limits: no speed clip needed
        return self._names, v0 + np.minimum(np.maximum(tgt[:, None, :] - v0, -reach), reach)

    def _escapes(self, cmd: np.ndarray) -> np.ndarray:
        """(M, H, 2): ``cmd`` for one interval, then each manoeuvre from there."""
        _, man = self.manoeuvres(cmd, self.horizon - 1)
        W = np.empty((len(self._names), self.horizon, 2))
        W[:, 0] = cmd
        W[:, 1:] = man
        return W

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
        if not np.all(np.isfinite(w)):
            return None, None, False
        seq = w.reshape(-1, 2)
        limited = not self.within_limits(state[3:5], seq)
        if limited:
            seq = self.limit(state[3:5], seq)
        return seq[0].copy(), (seq if plan is not None else None), limited

    def _check_best(self, state, wheels, obstacles, labels: list[str]) -> SafetyCheck:
        """The check of the best sequence of ``wheels`` (M, H, 2): the one that keeps the
        clearance above the threshold longest (a violation late in the horizon, where the
        forecasts are uncertain, is not as bad as one in the next second), then the one with
        the largest smallest clearance, then the first."""
        cmin, now, chord, which, kept = self.clearances(state, wheels, obstacles)
        i = 0
        if len(cmin) > 1:
            longest = kept == kept.max()
            i = int(np.argmax(longest & (cmin >= cmin[longest].max() - _TIE_M)))
        N, tau = self.horizon * self.substeps, self.sample_time_s / self.substeps
        return SafetyCheck(bool(kept[i] == N), float(cmin[i]), float(now[i]), float(chord[i] + 1) * tau,
                           obstacles.label(int(which[i])), labels[i], float(kept[i]) * tau)

    @staticmethod
    def _better(a: SafetyCheck, b: SafetyCheck) -> bool:
        """Whether ``a`` is strictly better than ``b`` by the order of :meth:`_check_best`."""
        return a.kept_s > b.kept_s + 1e-12 or (abs(a.kept_s - b.kept_s) <= 1e-12
                                               and a.min_clearance_m > b.min_clearance_m + _TIE_M)

    def _assess(self, state, cmd, plan, obstacles) -> SafetyCheck:
        """The check of a command (and its own plan, if any): its plan first; if that fails
        or there is none, the command followed by each manoeuvre (the best of them)."""
        horizon_s = self.horizon * self.sample_time_s
        if not len(obstacles.q):
            return SafetyCheck(True, math.inf, math.inf, 0.0, "", "", horizon_s)
        lower, j, k = self.bound(state, cmd, plan, obstacles)
        if lower >= self.margin_m:
            # far from everything whatever follows: no roll-out needed
            return SafetyCheck(True, lower, lower, (k + 1) * self.sample_time_s, obstacles.label(j), "bound",
                               horizon_s)
        if plan is not None:
            plan_check = self._check_best(state, plan[None], obstacles, ["plan"])
            if plan_check.safe:
                return plan_check
        way_out = self._check_best(state, self._escapes(cmd), obstacles, self._then_names)
        if plan is not None and self._better(plan_check, way_out):
            return plan_check
        return way_out

    def check(self, state, wheels, forecasts=(), statics=()) -> SafetyCheck:
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
        return self._assess(state, cmd, plan, self.obstacle_tracks(forecasts, statics))

    def best_manoeuvre(self, state, obstacles) -> tuple[str, np.ndarray, SafetyCheck]:
        """The best manoeuvre from now (see :meth:`_check_best`): name, (H, 2) wheels and its check."""
        names, W = self.manoeuvres(np.asarray(state, float)[3:5])
        check = self._check_best(np.asarray(state, float), W, obstacles, names)
        i = names.index(check.continuation)
        return names[i], W[i], check

    # --- the quick screen (plain floats) -------------------------------------------------
    # Most checks are passes; numpy's per-call overhead would make them cost more than the
    # network's own decision. So a candidate is first screened with plain floats by two lower
    # bounds of the clearance that the roll-out would find; only when neither keeps the
    # margin does the exact check above run. Both bounds are conservative: they can only
    # send a case to the exact check, never pass one it would fail by more than its own
    # chord error. (Clamps are written as conditional expressions: ``b if b > a else a`` is
    # max(a, b) and ``b if b < a else a`` is min(a, b), ties included, without the calls,
    # which were a third of the screen's time.)
    def _quick(self, robot: RobotState, wheels, forecasts, statics, poses=None):
        """(check, command, plan (H, 2) or None, limited) when the screen passes, else None.
        ``poses``: see :meth:`filter`."""
        H, T, W = self.horizon, self.sample_time_s, self.robot.wheel_base_m
        if type(wheels) is tuple and len(wheels) == 2:  # a command as two floats (the policy's)
            w, rows, own = None, [wheels], False
        else:
            w = wheels if isinstance(wheels, np.ndarray) else np.asarray(wheels, dtype=float)
            if w.shape == (2,):
                rows, own = [w.tolist()], False
            elif w.shape == (H, 2):
                rows, own = w.tolist(), True
            else:
                return None  # the exact path says what is wrong
        dv, vmax = self._dv, self.robot.max_wheel_speed_mps
        vr, vl = robot.v_right_mps, robot.v_left_mps
        seq, limited, changed = [], False, False
        isfinite, nvmax = math.isfinite, -vmax
        for r_, l_ in rows:
            if not (isfinite(r_) and isfinite(l_)):
                return None
            # min(max(min(max(r_, vr - dv), vr + dv), -vmax), vmax) (lo <= hi: a tie keeps
            # the value clamped, as min and max do), and the same for l_
            lo, hi = vr - dv, vr + dv
            a = r_ if lo <= r_ <= hi else lo if r_ < lo else hi
            nr = a if nvmax <= a <= vmax else nvmax if a < nvmax else vmax
            lo, hi = vl - dv, vl + dv
            a = l_ if lo <= l_ <= hi else lo if l_ < lo else hi
            nl = a if nvmax <= a <= vmax else nvmax if a < nvmax else vmax
            if nr != r_ or nl != l_:
                changed = True
                limited = limited or abs(nr - r_) > 1e-9 or abs(nl - l_) > 1e-9
            seq.append((nr, nl))
            vr, vl = nr, nl
        cmd = seq[0]
        obs = self._quick_obstacles(forecasts, statics)
        if obs is None:
            return None
        if not obs:
            return SafetyCheck(True, math.inf, math.inf, 0.0, "", "", H * T), cmd, self._plan(own, w, seq, changed), \
                limited
        p0 = complex(robot.x_m, robot.y_m)
        # 1. reach: over interval k the robot is within its path length S_k of where it is
        # (wheel speeds are held over each interval, so S_k sums |v_r + v_l| T / 2). A plan
        # is judged as itself; a command alone as the command followed by braking, the
        # shortest way out (if that keeps the margin, a way out exists)
        halfT = 0.5 * T
        if own:
            reach, acc = [], 0.0
            for a, b in seq:
                acc += abs(a + b) * halfT
                reach.append(acc)
        else:  # braking: each wheel moves towards 0 by at most dv per interval
            a, b = cmd
            acc = abs(a + b) * halfT
            reach = [acc]
            for _ in range(H - 1):
                a = a - dv if a > dv else a + dv if a < -dv else 0.0
                b = b - dv if b > dv else b + dv if b < -dv else 0.0
                acc += abs(a + b) * halfT
                reach.append(acc)
        low, where = math.inf, (0, 0)
        for j, (q, touch) in enumerate(obs):
            qk = q[0]
            for k in range(H):
                qk1 = q[k + 1]
                g = abs(p0 - qk1) - abs(qk1 - qk) - touch[k] - reach[k]
                if g < low:
                    low, where = g, (j, k)
                qk = qk1
        if low >= self.margin_m:
            check = SafetyCheck(True, low, low, (where[1] + 1) * T, self._quick_label(forecasts, where[0]),
                                "bound" if own else "bound, then brake", H * T, False)
            return check, cmd, self._plan(own, w, seq, changed), limited
        # 2. chords: the plan (or the command, then the usual way out, reversing) at the
        # sample instants; between two of them the relative motion is a straight chord within
        # |V| |A| T^2 / 8 of the arc (its largest departure, at any turn)
        if own:
            path, label = seq, "plan"
        else:
            path, label = self._then_target(cmd, self._reverse_target), "then reverse"
        sag_scale = T * T / (16.0 * W)
        sag = [abs(a + b) * abs(a - b) * sag_scale for a, b in path]
        if own and not changed and poses is not None:  # the caller's roll-out of this very plan
            xyh = poses.ravel().tolist()
            pts = [p0, *map(complex, xyh[0::3], xyh[1::3])]
        else:
            x, y, h = robot.x_m, robot.y_m, robot.heading_rad
            pts = [p0]
            for a, b in path:
                x, y, h = robot_step_float(x, y, h, a, b, T, W)
                pts.append(complex(x, y))
        low, where = math.inf, (0, 0)
        for j, (q, touch) in enumerate(obs):
            rel = list(map(operator.sub, pts, q))  # robot - obstacle at the sample instants
            for k, (r0, r1, tk, sk) in enumerate(zip(rel, rel[1:], touch, sag)):
                d = r1 - r0
                dr, di = d.real, d.imag
                dd = dr * dr + di * di
                if dd <= 1e-18:
                    t = 0.0
                else:  # min(max(., 0), 1)
                    t = -(r0.real * dr + r0.imag * di) / dd
                    t = 0.0 if 0.0 > t else t
                    t = 1.0 if 1.0 < t else t
                g = abs(r0 + t * d) - tk - sk
                if g < low:
                    low, where = g, (j, k)
        if low >= self.margin_m:
            check = SafetyCheck(True, low, low, (where[1] + 1) * T, self._quick_label(forecasts, where[0]), label,
                                H * T, False)
            return check, cmd, self._plan(own, w, seq, changed), limited
        return None

    @staticmethod
    def _plan(own: bool, w: np.ndarray, seq: list, changed: bool) -> np.ndarray | None:
        """The plan judged, as an array: ``np.array(seq)``, or a copy of the candidate
        ``w`` when the limits left it as it was (the same numbers, without the list)."""
        if not own:
            return None
        return w.copy() if not changed and w.dtype == np.float64 else np.array(seq)

    def _then_target(self, cmd, target) -> list[tuple[float, float]]:
        """``cmd`` for one interval, then towards the wheel speeds ``target`` (a manoeuvre's:
        braking (0, 0) or the ``reverse`` manoeuvre's) at the acceleration limit."""
        dv = self._dv
        tr, tl = target
        vr, vl = cmd
        out = [cmd]
        ndv = -dv
        for _ in range(self.horizon - 1):
            a = tr - vr  # vr + min(max(tr - vr, -dv), dv), and the same for vl
            a = ndv if ndv > a else a
            vr = vr + (dv if dv < a else a)
            a = tl - vl
            a = ndv if ndv > a else a
            vl = vl + (dv if dv < a else a)
            out.append((vr, vl))
        return out

    def _quick_obstacles(self, forecasts, statics):
        """Per obstacle: positions now and at steps 1..H (complex) and touching distances
        over each interval, in plain floats; None when a forecast has the wrong length (the
        exact path says so)."""
        H, R, k = self.horizon, self.robot.radius_m, self.sigmas
        hypot, sqrt = math.hypot, math.sqrt
        out = []
        for f in forecasts:
            m, c = f.means_m, _covs(f)
            if m.shape != (H, 2) or c.shape != (H, 2, 2):
                return None
            m, c = m.ravel().tolist(), c.ravel().tolist()
            q = list(map(complex, m[0::2], m[1::2]))
            q.insert(0, 2.0 * q[0] - q[1] if H > 1 else q[0])
            base = f.radius_m + R
            touch = []
            for a, b, d in zip(c[0::4], c[1::4], c[3::4]):  # cov = [[a, b], [b, d]]
                lam = 0.5 * (a + d) + hypot(0.5 * (a - d), b)
                touch.append(base + k * sqrt(0.0 if 0.0 > lam else lam))  # sqrt(max(lam, 0))
            out.append((q, touch))
        for st in statics:
            out.append(([complex(st.position_m[0], st.position_m[1])] * (H + 1), [st.radius_m + R] * H))
        return out

    @staticmethod
    def _quick_label(forecasts, j: int) -> str:
        return f"moving {forecasts[j].obstacle_id}" if j < len(forecasts) else f"static {j - len(forecasts)}"

    # --- the filter ----------------------------------------------------------------------
    def filter(self, observation: Observation, wheels, forecasts=(), statics=None, poses=None) -> SafetyVerdict:
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
        """
        statics = observation.static if statics is None else statics
        r = observation.robot
        self.counters["checks"] += 1
        for f in forecasts:
            if not getattr(f, "initialised", True):
                self.counters["unestimated_tracks"] += 1  # checked as the planner plans with it
        quick = self._quick(r, wheels, forecasts, statics, poses)
        if quick is not None:
            check, cmd, plan, limited = quick
            if limited:
                self.counters["candidate_limited"] += 1
            if self.fallback is not None and hasattr(self.fallback, "observe"):
                self.fallback.observe(observation)
            return SafetyVerdict(cmd[0], cmd[1], False, "", "candidate", check, plan)
        state = np.array([r.x_m, r.y_m, r.heading_rad, r.v_right_mps, r.v_left_mps], dtype=float)
        obstacles = self.obstacle_tracks(forecasts, statics)
        cmd, plan, limited = self._as_candidate(state, wheels)
        if cmd is None:
            self.counters["non_finite_candidate"] += 1
            check = SafetyCheck(False, -math.inf, -math.inf, 0.0, "", "non-finite candidate", 0.0)
            return self._intervene(observation, state, obstacles, check, None)
        if limited:
            # the simulator (and the robot) would clip it: what is checked is what would happen
            self.counters["candidate_limited"] += 1
        check = self._assess(state, cmd, plan, obstacles)
        if check.safe:
            if self.fallback is not None and hasattr(self.fallback, "observe"):
                self.fallback.observe(observation)
            return SafetyVerdict(float(cmd[0]), float(cmd[1]), False, "", "candidate", check, plan)
        return self._intervene(observation, state, obstacles, check, cmd)

    def _intervene(self, observation, state, obstacles, check: SafetyCheck, cmd) -> SafetyVerdict:
        self.counters["interventions"] += 1
        if math.isfinite(check.min_clearance_m):
            why = (f"safety: {check.obstacle} predicted clearance {check.min_clearance_m:.2f} m at "
                   f"+{check.time_s:.1f} s (margin {self.margin_m:.2f} m)")
        else:
            why = f"safety: {check.continuation}"
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
                name, mw, mc = self.best_manoeuvre(state, obstacles)
                if pcheck is not None and not self._better(mc, pcheck) and (
                        cmd is None or not self._better(check, pcheck)):
                    self.counters["fallback_used"] += 1
                    return SafetyVerdict(float(pcmd[0]), float(pcmd[1]), True,
                                         why + "; fallback planner (no manoeuvre does better)", "fallback", check,
                                         pplan)
                self.counters["fallback_overruled"] += 1
                if cmd is not None and not self._better(mc, check):
                    # e.g. a track seen once, whose unknown motion makes every option fail far
                    # ahead: the candidate keeps the margin longest, so it stays
                    self.counters["no_safer_option"] += 1
                    return SafetyVerdict(float(cmd[0]), float(cmd[1]), True,
                                         why + "; fallback planner's answer fails the check, no manoeuvre does "
                                         "better: candidate kept", "candidate", check, None)
                self.counters["manoeuvres"] += 1
                return SafetyVerdict(float(mw[0, 0]), float(mw[0, 1]), True,
                                     why + f"; fallback planner's answer fails the check, manoeuvre {name} "
                                     f"(clearance {mc.min_clearance_m:.2f} m, margin kept {mc.kept_s:.1f} s)",
                                     f"manoeuvre:{name}", check, mw)
            self.counters["fallback_failed"] += 1
            why += f"; fallback planner failed ({dec.reason})"
        name, mw, mc = self.best_manoeuvre(state, obstacles)
        if cmd is not None and not self._better(mc, check):
            # nothing in the set does better than the candidate: keep it, and say so
            self.counters["no_safer_option"] += 1
            return SafetyVerdict(float(cmd[0]), float(cmd[1]), True, why + "; no safer manoeuvre, candidate kept",
                                 "candidate", check, None)
        self.counters["manoeuvres"] += 1
        return SafetyVerdict(float(mw[0, 0]), float(mw[0, 1]), True,
                             why + f"; manoeuvre {name} (clearance {mc.min_clearance_m:.2f} m, margin kept "
                             f"{mc.kept_s:.1f} s)", f"manoeuvre:{name}", check, mw)


def _covs(f) -> np.ndarray:
    """The forecast covariances the check uses: the planner's (a track seen once keeps its
    next step's uncertainty; objects without ``initialised`` are estimated tracks)."""
    return planning_covariances(f.covs_m2, getattr(f, "initialised", True))


class _Obstacles:
    """The obstacles of one check at the sample instants, with their sub-sampled form made
    once when a roll-out needs it."""

    __slots__ = ("q", "touch", "moving", "statics", "_filter", "_sub")

    def __init__(self, q, touch, moving, statics, flt: SafetyFilter):
        self.q, self.touch, self.moving, self.statics, self._filter, self._sub = q, touch, moving, statics, flt, None

    def sub_samples(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions ``(n, H * substeps + 1)`` and touching distances ``(n, H * substeps)``."""
        if self._sub is None:
            f = self._filter
            self._sub = (self.q @ f._interp, np.repeat(self.touch, f.substeps, axis=1))
        return self._sub

    def label(self, j: int) -> str:
        n = len(self.moving)
        return f"moving {self.moving[j].obstacle_id}" if j < n else f"static {j - n}"


class StandbyPlanner:
    """A planner kept on standby: it is told every observation but solves only when asked.

    ``observe(observation)`` stores the observation; ``decide(observation)`` first replays
    the stored ones through the planner's estimation and reference clock (its
    ``estimate`` and ``desired_poses``, or its ``decide`` when it has neither) so that its
    obstacle filters and clock are exactly where they would have been, then decides. So
    the GPC behind a network costs nothing while the network is trusted. At most
    ``max_lag`` observations wait: beyond that the oldest is replayed at once, which bounds
    the catch-up time of a long run.
    """

    def __init__(self, planner, max_lag: int = 400):
        if not callable(getattr(planner, "decide", None)):
            raise TypeError("planner must have a decide(observation) method")
        self.planner = planner
        self.max_lag = int(max_lag)
        self.sample_time_s = getattr(planner, "sample_time_s", None)
        self._pending: list[Observation] = []
        self.replayed = 0

    @property
    def counters(self) -> dict:
        return getattr(self.planner, "counters", {})

    def reset(self) -> None:
        if hasattr(self.planner, "reset"):
            self.planner.reset()
        self._pending = []
        self.replayed = 0

    def _replay(self, obs: Observation) -> None:
        p = self.planner
        if hasattr(p, "estimate") and hasattr(p, "desired_poses"):
            p.estimate(obs)
            p.desired_poses(obs)
        else:
            p.decide(obs)
        self.replayed += 1

    def observe(self, observation: Observation) -> None:
        self._pending.append(observation)
        while len(self._pending) > self.max_lag:
            self._replay(self._pending.pop(0))

    def decide(self, observation: Observation) -> ControlDecision:
        for obs in self._pending:
            self._replay(obs)
        self._pending = []
        return self.planner.decide(observation)
