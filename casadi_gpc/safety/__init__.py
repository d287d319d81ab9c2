"""The safety check layer: check a controller's wheel speeds against the predicted
obstacles and replace them when they come too close (numpy, and numba for the compiled
distances, :mod:`casadi_gpc.safety.distances`: imports without CasADi).

:class:`Shield` puts any controller behind it (the GPC, the network, the peers, a user's
own): ``Shield(policy)`` answers the same Policy protocol. Neither a network that imitates an
optimiser nor an optimiser whose obstacle terms are soft penalties has a guarantee of its
own. Each sample, :class:`SafetyFilter`
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
whole horizon. When the robot is already inside an obstacle's margin (one first seen close
by), a sequence that makes the clearance to it no smaller than it is now also passes (to that
obstacle: the others keep their own margins). Otherwise
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
   wheel-speed target approached at the acceleration limit. Best means
   (:meth:`TrajectoryCheck._better`): one that keeps the margin over the horizon (the
   largest smallest clearance among those); among those that all lose it, the one that
   drives into a contact latest within the commitment time
   (:attr:`SafetyCheck.drives_in_s`: a contact that cannot be avoided is met standing or
   giving way, not driving), then the one that stays clear of the obstacles' expected discs
   longest (:attr:`SafetyCheck.contact_s`), then off the walls and static obstacles longest,
   then the one that keeps the margin longest (a violation late in the horizon, where the
   forecast's uncertainty has grown, is not as bad as one in the next second), then the
   largest smallest clearance, then the earlier one in :data:`MANOEUVRES` (braking first).
   If none is better than the candidate itself, the candidate is kept and that is counted
   (``no_safer_option``; not in ``interventions``, the decisions the check changed).

A moving obstacle seen only once (``initialised`` false on the policy's track estimate:
speed and heading unknown) is checked as the planner plans with it
(:func:`casadi_gpc.estimation.ekf.planning_covariances`): standing where it was seen, with its next
step's uncertainty; each such check is counted (``unestimated_tracks``). The EKF's own
forecast grows that uncertainty without information, so that every option "fails" it some
seconds ahead; the next sample gives it a velocity and the full check.

Every check and every intervention is counted in :attr:`SafetyFilter.counters`.
``docs/faults.md`` documents the settings and the measured cost.

Before the fallback planner and the manoeuvres, a controller's own alternatives
(``ControlDecision.alternatives``: the planner's other solved candidates, best first) are
tried: the first that passes is taken (counted ``alternative_used``), and the best of them
competes with the candidate where nothing passes. With ``safer_alternatives`` (the
``improved`` planner, :data:`SAFER_ALTERNATIVES`), a plan that passes on the planner's
trust time alone gives way to the first alternative that keeps the margin over the whole
horizon (counted ``alternative_safer``).

Walls (``Observation.walls``) are judged as their segments: the clearance to a wall is the
distance from the robot's centre to its nearest segment less the robot's radius, with the
margin as for a static obstacle, and between two sub-samples the distance between the
robot's chord and the segment (:mod:`casadi_gpc.safety.walls`).

Rooms: ``check`` (the verdict on a sequence, the manoeuvres and the grid a way out is
searched in), ``clearances`` (the roll-out and the clearances along it, to discs and to wall
segments), ``search`` (the searched way out),
``obstacles`` (the forecasts as the arrays a check
reads), ``screen`` (the quick screen in plain floats in front of the check),
``filter`` (:class:`SafetyFilter`: the interventions and their counters), ``settings``
(:class:`CheckSettings`: what the check trusts from a controller and what it falls back
on, one frozen object per controller), ``shield`` (:class:`Shield`: any controller behind
the filter, its forecasts or the shield's own), ``standby`` (:class:`StandbyPlanner`, the
planner kept in step behind the filter) and ``walls`` (the observation's walls as segments, and the distances to them).
"""
from .check import MANOEUVRES, SafetyCheck, TrajectoryCheck
from .filter import ROLLOUT_TRUST_S, SAFER_ALTERNATIVES, SafetyFilter, SafetyVerdict, safer_alternatives_for
from .settings import FALLBACKS, CheckSettings
from .shield import Shield
from .standby import StandbyPlanner

__all__ = ["MANOEUVRES", "ROLLOUT_TRUST_S", "SAFER_ALTERNATIVES", "CheckSettings", "FALLBACKS", "SafetyCheck",
           "SafetyVerdict", "SafetyFilter", "Shield", "StandbyPlanner", "TrajectoryCheck", "safer_alternatives_for"]
