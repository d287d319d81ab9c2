"""MPPI (Williams et al. 2017; the sampler behind nav2's MPPI controller) on the GPC's own
problem: ``pytorch_mppi.MPPI`` (``pip install pytorch-mppi``, needs torch: the ``train``
extra) minimising the GPC's cost, written once in :mod:`casadi_gpc.problem.cost`.

What MPPI and the GPC share, so that only the optimiser differs:

- the decision variables: the wheel-speed increments of the H steps of one sample time T
  each (the preset's T and H), bounded by the acceleration limit;
- the cost: the GPC's ``cost_fn(u, p)`` (tracking, effort, turning, obstacles, margin;
  :func:`casadi_gpc.problem.cost.build_problem`), evaluated for all samples in one call of its
  CasADi ``map``: nothing of the cost is written a second time;
- its parameters: the same EKF bank's forecasts per step (:class:`~casadi_gpc.estimation.tracking.TrackBank`),
  the same reference clock (:class:`~casadi_gpc.progress.ReferenceClock`) and the same
  obstacle selection and packing (:func:`casadi_gpc.problem.selection.planner_parameters`);
- the walls, as the GPC takes them: where the preset has wall slots
  (``PlannerConfig.max_walls``; :meth:`~casadi_gpc.config.PlannerConfig.for_walls`, which the
  command line applies to a run with walls), the segments nearest the predicted path fill
  them and the cost prices the robot's clearance to each as the paper prices a static
  obstacle: a barrier that grows without bound as the clearance closes (a sample that
  touches a wall costs more than any that does not), and the improved preset's margin
  penalty. Segments that did not fit are counted (``walls_left_out``); walls in an
  observation for a preset with no slots are counted too (``walls_unpriced``, decisions):
  nothing is dropped silently.

MPPI's own state is the two wheel speeds: its dynamics add an increment and clip at the
wheel limit (the NLP's constraint); the increments actually applied (after the clip) are
the ones whose cost is evaluated. The robot's motion is the cost function's own roll-out.
Sampling draws from a torch generator seeded at ``reset``, so an episode is reproducible.
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np

from casadi_gpc.config import PlannerConfig, preset
from casadi_gpc.problem.cost import build_problem, to_world
from casadi_gpc.progress import ReferenceClock
from casadi_gpc.robot import RobotParams
from casadi_gpc.problem.selection import planner_parameters
from casadi_gpc.estimation.tracking import TrackBank
from casadi_gpc.types import ControlDecision, Observation

__all__ = ["MPPISettings", "MPPIPeer"]


@dataclass(frozen=True)
class MPPISettings:
    """pytorch-mppi's settings (``docs/peers.md`` has the sweep behind them)."""

    samples: int = 500
    """K, sampled control sequences per decision. 2000 tracked no better on the
    development episodes and is four times as slow."""
    noise_std_mps: float = 0.05
    """Standard deviation of the sampled wheel-speed increments per step (m/s), each wheel.
    The GPC's cost charges increments (lambda1 = 63 per (m/s)^2), so noise is expensive: at
    0.2 m/s a random sample's effort alone costs about 60, and on an empty path MPPI's mean
    closed-loop cost was 75; at 0.05, 18 (the GPC's: 2.4), with as many development crowd
    and random-multi episodes reached (docs/peers.md)."""
    temperature: float = 1.0
    """lambda, in units of the GPC's cost J. 0.3 and 10 were no better."""
    iterations: int = 1
    """MPPI updates per decision, each with K new samples around the last (the first after
    shifting the previous plan by a step). One, as nav2 runs it: three cost three times as
    much and tracked no better on the development episodes."""
    seed: int = 0
    """Seed of the sampling noise, reset with every episode."""
    torch_threads: int | None = 1
    """torch's intra-op threads, set for the whole process when the peer is made (None:
    left as they are). One: the tensors are small (a decision took 22 ms with one thread,
    28 ms with two on this machine), and the worker pool runs one episode per core."""


class MPPIPeer:
    """pytorch-mppi on the GPC's problem, answering the Policy protocol.

    Parameters
    ----------
    settings : MPPISettings
    config : PlannerConfig
        The planner preset whose cost, T and H are used (default ``improved``).
    robot : RobotParams
    """

    name = "MPPI"
    provides_forecasts = True
    """Its decisions carry the EKF bank's forecasts (a Shield checks against those)."""

    def __init__(self, settings: MPPISettings | None = None, config: PlannerConfig | None = None,
                 robot: RobotParams | None = None):
        import torch
        self.settings = settings or MPPISettings()
        self.config = config or preset("improved")
        self.robot = robot or RobotParams()
        if self.settings.samples < 1 or self.settings.iterations < 1:
            raise ValueError(f"MPPI needs at least one sample and one iteration, got {self.settings}")
        if self.settings.torch_threads is not None:
            torch.set_num_threads(self.settings.torch_threads)
        self.problem = build_problem(self.config, self.robot)
        self.sample_time_s = self.config.sample_time_s
        self._cost_of_samples = self.problem.cost_fn.map(self.settings.samples)
        self.reset()

    def reset(self) -> None:
        import torch
        from pytorch_mppi import MPPI
        s, cfg = self.settings, self.config
        H, T = cfg.horizon, cfg.sample_time_s
        dv, vmax = self.robot.max_step_change_mps(T), self.robot.max_wheel_speed_mps
        f64 = torch.float64
        self.counters = {"missed_measurements": 0, "outliers": 0, "unestimated_tracks": 0,
                         "walls_left_out": 0, "walls_unpriced": 0}
        self.bank = TrackBank(T, counters=self.counters, straight=cfg.forecast == "straight")  # the GPC's forecast
        self.clock = ReferenceClock(T, cfg.max_lead_m)
        self._generator_state = torch.Generator().manual_seed(s.seed).get_state()
        self._x0 = np.zeros(5)
        self._p = None
        self._path_xy = None  # the last plan's positions at steps 1..H
        def dynamics(wheels, increment):
            return torch.clamp(wheels + increment, -vmax, vmax)

        def no_running_cost(wheels, increment):
            return torch.zeros(wheels.shape[0], dtype=wheels.dtype)

        with self._own_generator():  # pytorch-mppi draws its first plan from torch's generator
            self.mppi = MPPI(dynamics, no_running_cost, 2, torch.eye(2, dtype=f64) * s.noise_std_mps ** 2,
                             num_samples=s.samples, horizon=H, lambda_=s.temperature,
                             noise_mu=torch.zeros(2, dtype=f64), u_init=torch.zeros(2, dtype=f64),
                             u_min=torch.full((2,), -dv, dtype=f64), u_max=torch.full((2,), dv, dtype=f64),
                             terminal_state_cost=self._sequence_costs)
        self.mppi.U = torch.zeros(H, 2, dtype=f64)  # start from standing still, not from noise

    @contextlib.contextmanager
    def _own_generator(self):
        """pytorch-mppi draws from torch's global generator: swap this peer's own in (seeded
        at ``reset``) and give the caller's back."""
        import torch
        saved = torch.random.get_rng_state()
        torch.random.set_rng_state(self._generator_state)
        try:
            yield
        finally:
            self._generator_state = torch.random.get_rng_state()
            torch.random.set_rng_state(saved)

    def _sequence_costs(self, wheels, increments):
        """The GPC's cost of every sampled sequence: ``wheels`` (1, K, H, 2) are the wheel
        speeds after each step; the increments applied are their differences."""
        import torch
        w = wheels[0]
        start = torch.as_tensor(self._x0[3:5], dtype=w.dtype).expand(w.shape[0], 1, 2)
        applied = torch.diff(torch.cat([start, w], dim=1), dim=1)           # (K, H, 2)
        u = applied.reshape(w.shape[0], -1).T.numpy()                        # (2H, K), [dVr_0, dVl_0, ...]
        return torch.as_tensor(np.asarray(self._cost_of_samples(u, self._p)).ravel(), dtype=w.dtype)

    def parameters(self, observation: Observation) -> np.ndarray:
        """The GPC's NLP parameters for this observation, made as
        :meth:`casadi_gpc.planner.gpc.GPCController.decide` makes them (its EKF bank, reference clock,
        obstacle selection by relevance to the last plan's path, wall selection, and packing): one step of
        the bank and the clock, so call once per decision. The forecasts are kept for the
        decision."""
        cfg = self.config
        H = cfg.horizon
        forecasts = [self.bank.forecast(m, ekf, H) for m, ekf in self.bank.step(observation.moving, observation.t_s)]
        path = observation.reference
        self.clock.update(path, observation.t_s, (observation.robot.x_m, observation.robot.y_m))
        ref = np.array(path.poses_along(self.clock.s_m, path.speed_mps * cfg.sample_time_s, H + 1))  # steps 0..H
        path_xy = ref[1:, :2] if self._path_xy is None else np.vstack([self._path_xy[1:], self._path_xy[-1:]])
        p, sel = planner_parameters(self.problem.layout, observation.robot.as_array(), ref, forecasts,
                                    observation.static, cfg, path_xy, observation.walls)
        self.counters["walls_left_out"] += sel.walls_left_out
        if observation.walls and not cfg.max_walls:
            self.counters["walls_unpriced"] += 1
        self._forecasts = tuple(forecasts)
        return p

    def decide(self, observation: Observation) -> ControlDecision:
        import torch
        self._p = self.parameters(observation)
        self._x0 = observation.robot.as_array()
        with self._own_generator():
            state = torch.as_tensor(self._x0[3:5])
            for i in range(self.settings.iterations):
                self.mppi.command(state, shift_nominal_trajectory=i == 0)
        U = self.mppi.U.detach().numpy()                                      # (H, 2) increments
        vmax = self.robot.max_wheel_speed_mps
        wheels = [self._x0[3:5]]
        for increment in U:                                                  # as the dynamics clip
            wheels.append(np.clip(wheels[-1] + increment, -vmax, vmax))
        applied = np.diff(np.asarray(wheels), axis=0).reshape(-1)
        poses, planned = (np.asarray(a) for a in self.problem.rollout_fn(applied, self._p))
        poses = to_world(poses, self._x0)  # the NLP's frame (casadi_gpc.problem.cost.frame_origin) to the map's
        cost = float(self.problem.cost_fn(applied, self._p))
        self._path_xy = poses[:, :2]
        return ControlDecision(float(planned[0, 0]), float(planned[0, 1]), reason="mppi",
                               planned_wheels_mps=planned, planned_poses=poses, cost=cost, forecasts=self._forecasts)
