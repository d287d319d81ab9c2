"""The quick screen: most checks are passes, and numpy's per-call overhead would make them
cost more than the network's own decision, so a candidate is first screened with plain
floats (among many obstacles, compiled loops over arrays) by lower bounds of the clearance
that the exact roll-out would find: the reach of the command then braking, the chords of the
command then reversing, and the chords of the command then each fixed manoeuvre (see
:mod:`casadi_gpc.safety`)."""
from __future__ import annotations

import math
import operator

import numpy as np

from ..robot import RobotState, robot_step_float
from .check import SafetyCheck, TrajectoryCheck, forecast_arrays, forecast_covariances
from .distances import chord_bound, escape_bounds, reach_bound, screen_obstacles
from .obstacles import Obstacles
from .walls import path_segment_distances, wall_label

__all__ = ["QuickScreen"]


class QuickScreen(TrajectoryCheck):
    """The exact check with the quick screen in front of it (:meth:`_quick`)."""

    _screen_memo = None  # (forecasts, statics, the screen's arrays) within one filter call

    # Most checks are passes; numpy's per-call overhead would make them cost more than the
    # network's own decision. So a candidate is first screened with plain floats by lower
    # bounds of the clearance that the roll-out would find; only when none keeps the
    # margin does the exact check above run. All are conservative: they can only
    # send a case to the exact check, never pass one it would fail by more than its own
    # chord error. (Clamps are written as conditional expressions: ``b if b > a else a`` is
    # max(a, b) and ``b if b < a else a`` is min(a, b), ties included, without the calls,
    # which were a third of the screen's time.)
    def _quick(self, robot: RobotState, wheels, forecasts, statics, poses=None, walls=None):
        """(check, command, plan (H, 2) or None, limited) when the screen passes, else None.
        ``poses``: see :meth:`filter`; ``walls``: the wall segments (:mod:`.walls`)."""
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
        many = len(forecasts) + len(statics) >= MANY_OBSTACLES
        if many:
            # the command's screen and its roll-out's read the same obstacles in one filter call:
            # their arrays made once (filter() clears the memo when it starts and ends)
            memo = self._screen_memo
            if memo is not None and memo[0] is forecasts and memo[1] is statics:
                obs = memo[2]
            else:
                obs = self._quick_obstacle_arrays(forecasts, statics)
                self._screen_memo = (forecasts, statics, obs)
        else:
            obs = self._quick_obstacles(forecasts, statics)
        if obs is None:
            return None
        has_walls = walls is not None and len(walls) > 0
        if not obs and not has_walls:
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
        if many:
            low, where = _reach_bound_arrays(p0, obs, reach)
        else:
            low, where = math.inf, (0, 0)
            for j, (q, touch) in enumerate(obs):
                qk = q[0]
                for k in range(H):
                    qk1 = q[k + 1]
                    g = abs(p0 - qk1) - abs(qk1 - qk) - touch[k] - reach[k]
                    if g < low:
                        low, where = g, (j, k)
                    qk = qk1
        if has_walls:
            low, where = self._wall_bound(low, where, self.wall_bounds(p0, walls, reach), forecasts, statics)
        if low >= self.margin_m:
            check = SafetyCheck(True, low, low, (where[1] + 1) * T, self._quick_label(forecasts, statics, where[0]),
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
        if many and not own:  # the path's chord bound in one compiled call (the same numbers as below)
            low, _, j, k = escape_bounds(float(robot.x_m), float(robot.y_m), float(robot.heading_rad),
                                         np.array(path, dtype=float).reshape(1, H, 2), T, W, sag_scale, obs[0], obs[1],
                                         walls if has_walls else _NO_WALLS, self.robot.radius_m)
            if low >= self.margin_m:
                check = SafetyCheck(True, low, low, (k + 1) * T, self._quick_label(forecasts, statics, j), label,
                                    H * T, False)
                return check, cmd, None, limited
            return self._quick_escapes(robot, cmd, obs, walls, limited, forecasts, statics)
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
        if many:
            low, where = _chord_bound_arrays(pts, obs, sag)
        else:
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
        if has_walls:  # the chords' distances to the segments, less the arcs' sag
            gw = path_segment_distances(np.array(pts), walls) - self.robot.radius_m - np.asarray(sag)
            low, where = self._wall_bound(low, where, gw, forecasts, statics)
        if low >= self.margin_m:
            check = SafetyCheck(True, low, low, (where[1] + 1) * T, self._quick_label(forecasts, statics, where[0]),
                                label, H * T, False)
            return check, cmd, self._plan(own, w, seq, changed), limited
        if own:
            return None
        # 3. the command, then each of the exact check's fixed manoeuvres, at the sample
        # instants as in 2. (compiled): one whose chords keep the margin is a way out
        return self._quick_escapes(robot, cmd, obs, walls, limited, forecasts, statics)

    def _quick_escapes(self, robot: RobotState, cmd, obs, walls, limited: bool, forecasts, statics):
        """The screen's third bound (:meth:`_quick`): the best of the chord bounds of the
        command followed by each manoeuvre (:meth:`_escapes`, the exact check's first set),
        as the screen's answer when it keeps the margin, else None."""
        H, T, W = self.horizon, self.sample_time_s, self.robot.wheel_base_m
        if isinstance(obs, list):  # the plain-float form, as arrays
            q = np.array([o[0] for o in obs], dtype=complex).reshape(len(obs), H + 1)
            touch = np.array([o[1] for o in obs], dtype=float).reshape(len(obs), H)
        else:
            q, touch = obs
        low, m, j, k = escape_bounds(float(robot.x_m), float(robot.y_m), float(robot.heading_rad),
                                     self._escapes(np.array(cmd, dtype=float)), T, W, T * T / (16.0 * W), q, touch,
                                     _NO_WALLS if walls is None else walls, self.robot.radius_m)
        if not low >= self.margin_m:
            return None
        check = SafetyCheck(True, low, low, (k + 1) * T, self._quick_label(forecasts, statics, j), self._then_names[m],
                            H * T, False)
        return check, cmd, None, limited

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
            m, c = f.means_m, forecast_covariances(f)
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

    def _quick_obstacle_arrays(self, forecasts, statics):
        """:meth:`_quick_obstacles` as two arrays, for many obstacles: positions now and at
        steps 1..H, ``(n, H + 1)`` complex, and touching distances, ``(n, H)``; the same
        numbers (each entry by the same operations)."""
        H, R, k = self.horizon, self.robot.radius_m, self.sigmas
        n_mov = len(forecasts)
        if n_mov:
            try:
                m, c, w = forecast_arrays(forecasts)
            except ValueError:
                return None  # the exact path says what is wrong
            if m.shape != (n_mov, H, 2) or c.shape != (n_mov, H, 2, 2):
                return None
        else:
            m, w = np.zeros((0, H, 2)), np.zeros((0, H))
        radii = np.array([f.radius_m for f in forecasts], dtype=float) + R
        sxy = np.array([st.position_m for st in statics], dtype=float).reshape(-1, 2)
        return screen_obstacles(m, w, radii, k, sxy, np.array([st.radius_m for st in statics], dtype=float) + R)

    def _screened_obstacles(self, forecasts, statics, walls):
        """:meth:`obstacle_tracks` made from the screen's arrays of this filter call (:meth:`_quick`
        among many obstacles), or None when it made none for these obstacles. The same numbers:
        an obstacle's position now is ``2 q_1 - q_2`` in both (in the exact form's product with
        ``_known`` that subtraction is the one rounding: the other products are by 1, 2, -1 and
        0, exact), its later positions are copies, its touching distances the same sums."""
        memo = self._screen_memo
        if memo is None or memo[0] is not forecasts or memo[1] is not statics or memo[2] is None:
            return None
        q, touch = memo[2]
        R = self.robot.radius_m
        radii = np.concatenate([np.array([f.radius_m for f in forecasts], dtype=float) + R,
                                np.array([st.radius_m for st in statics], dtype=float) + R])
        return Obstacles(q, touch, tuple(forecasts), tuple(statics), self, radii, walls)

    @staticmethod
    def _wall_bound(low: float, where: tuple, walls_low: np.ndarray, forecasts, statics) -> tuple[float, tuple]:
        """The smaller of the discs' bound ``low`` (at ``where``) and the walls' ``(nw, H)``
        (the discs' on a tie), with where it is (walls indexed after the discs)."""
        i = int(np.argmin(walls_low))
        j, k = divmod(i, walls_low.shape[1])
        g = float(walls_low[j, k])
        return (g, (len(forecasts) + len(statics) + j, k)) if g < low else (low, where)

    @staticmethod
    def _quick_label(forecasts, statics, j: int) -> str:
        n = len(forecasts)
        if j < n:
            return f"moving {forecasts[j].obstacle_id}"
        return f"static {j - n}" if j < n + len(statics) else wall_label(j - n - len(statics))


MANY_OBSTACLES = 4
"""From this many obstacles on, the quick screen's two bounds are taken over arrays by compiled
loops (:mod:`casadi_gpc.safety.distances`; the same operations on each entry); below it, plain
floats cost less than making the arrays. Measured in a crowd of ten walkers: the screen
took about half a millisecond in plain floats."""


def _reach_bound_arrays(p0: complex, obs, reach) -> tuple[float, tuple[int, int]]:
    """The reach bound (:meth:`QuickScreen._quick`, 1.) over arrays (compiled,
    :func:`~casadi_gpc.safety.distances.reach_bound`): its least value and where, the first
    (obstacle, step) in row order on a tie, as the loop finds it."""
    g, j, k = reach_bound(p0, obs[0], obs[1], np.array(reach, dtype=float))
    return g, (j, k)


def _chord_bound_arrays(pts, obs, sag) -> tuple[float, tuple[int, int]]:
    """The chord bound (:meth:`QuickScreen._quick`, 2.) over arrays, as the loop takes it
    (compiled, :func:`~casadi_gpc.safety.distances.chord_bound`)."""
    g, j, k = chord_bound(np.array(pts, dtype=complex), obs[0], obs[1], np.array(sag, dtype=float))
    return g, (j, k)


_NO_WALLS = np.zeros((0, 2), dtype=complex)  # empty: nothing to write
