"""The paper's training distribution: situations for its two passes, labelled by the GPC.

The paper runs its network twice (section 4): first without obstacles, to predict the
robot's next H poses along the desired trajectory; then, if that prediction comes near an
obstacle, with the obstacles and the prediction as the new desired trajectory. Its symmetry
argument rests on this: "it has been supposed that the robot is always on the desired
path". So the obstacle-avoiding network only ever sees a robot standing at the start of a
smooth desired trajectory that continues its own motion, and the first pass only ever
sees the obstacle-free tracking problem.

One draw here gives both (:func:`two_pass_samples`):

1. **first pass**: a tracking situation (the sampler's path and robot, beside the path or
   on it, :class:`~nn_export.training.sampler.SamplerSettings`) without obstacles, and the
   GPC's answer to it;
2. **second pass**: the same robot with the GPC's obstacle-free plan from (1) as the
   desired trajectory (step 0: the robot's own pose; steps 1..H: the planned poses, which
   is what a first pass that imitates the GPC predicts), one moving obstacle drawn against
   that trajectory where the deployed policy would run its second pass, and the GPC's
   answer to it.

Each situation's mirror image is added by the dataset writer as for any situation
(reflected about the desired trajectory's tangent at the robot: the paper's symmetry).
Situations carry ``info["decision_pass"]`` (1 or 2), stored in the shards.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.robot import RobotParams, RobotState, robot_step
from casadi_gpc.types import ControlDecision, Observation

from ..runtime.situation import Situation
from ..runtime.tracker import SituationTracker
from .labels import Label, Labeller
from .sampler import SamplerSettings, sample_situation, situation_from_tail

__all__ = ["SETTINGS", "predicted_poses", "two_pass_samples", "two_pass_stream", "TwoPassGPC"]

SETTINGS = SamplerSettings(p_tracking=0.6, recovering_lateral_m=(-2.0, 2.0), recovering_heading_rad=(-1.0, 1.0),
                           speed_ratio=(0.2, 1.8))
"""The sampler's settings for the two-pass scheme: the robot strays farther from the path
than under the planner's scheme (up to 2 m, 1 rad, 1.8 times the reference speed), because
the first pass must bring it back from wherever the second pass's evasion took it (a
network trained on +-1.2 m went unstable at 1.7 m beside the path after Fig. 7.2's
crossing, measured)."""


def predicted_poses(situation: Situation, plan_wheels_mps: np.ndarray, robot: RobotParams) -> np.ndarray:
    """The poses at steps 0..H of the robot driven by ``plan_wheels_mps`` (H, 2) from its
    state in ``situation``: the first pass's prediction, the second pass's desired
    trajectory (step 0: the robot's pose)."""
    r = situation.robot
    x, y, h = r.x_m, r.y_m, r.heading_rad
    poses = [(x, y, h)]
    for vr, vl in np.asarray(plan_wheels_mps, dtype=float):
        x, y, h = (float(a) for a in robot_step(np, x, y, h, vr, vl, situation.sample_time_s, robot.wheel_base_m))
        poses.append((x, y, h))
    return np.array(poses)


def first_pass_prediction(labeller: Labeller, situation: Situation, ref_ahead: np.ndarray, mode: str = "rollout",
                          first: Label | None = None) -> tuple[np.ndarray, np.ndarray] | None:
    """The first pass with the GPC as the network: the robot's poses at steps 0..H and its
    wheel speeds (H, 2), as if there were no obstacle; None if a label did not converge.

    ``mode``: ``"rollout"``, as the deployed policy predicts (the obstacle-free answer
    applied step by step, step j with the desired poses ``ref_ahead[j:j + H + 1]``; needs
    ``ref_ahead`` of 2H poses), or ``"plan"`` (the GPC's open-loop plan from now).
    ``first``: the label of the obstacle-free situation now, if already solved."""
    free = situation.without_obstacles()
    robot = labeller.robot
    if mode == "plan":
        label = first or labeller.label(free)
        return (predicted_poses(free, label.plan_wheels_mps, robot), label.plan_wheels_mps) if label.converged else None
    H, W, T = situation.horizon, robot.wheel_base_m, situation.sample_time_s
    state, poses, wheels = situation.robot, [situation.robot.as_array()[:3]], []
    for j in range(H):
        # each step labelled as the dataset labels (every guess): what a network that
        # imitates the labels predicts
        label = first if j == 0 and first is not None else labeller.label(
            replace(free, robot=state, ref_poses=ref_ahead[j:j + H + 1]))
        if not label.converged:
            return None
        vr, vl = (float(v) for v in label.wheels_mps)
        x, y, h = (float(a) for a in robot_step(np, state.x_m, state.y_m, state.heading_rad, vr, vl, T, W))
        state = RobotState(x, y, h, vr, vl)
        poses.append((x, y, h))
        wheels.append((vr, vl))
    return np.array(poses, dtype=float), np.array(wheels)


class _Unlabelled(Exception):
    """The first pass's situation had no converged GPC answer: draw again."""


def two_pass_samples(rng: np.random.Generator, config: PlannerConfig, labeller: Labeller,
                     robot: RobotParams | None = None, settings: SamplerSettings | None = None,
                     tracker: SituationTracker | None = None) -> list[tuple[Situation, Label]]:
    """One draw: ``[(first-pass situation, its label), (second-pass situation, its label)]``
    (the second label may be unconverged; the first is converged, else the draw is repeated)."""
    robot = robot or RobotParams()
    tracker = tracker or SituationTracker(config, reference_steps=2 * config.horizon - 1)
    first: list = []

    def first_pass(free_tail, mode: str):
        sit = situation_from_tail(free_tail, config, tracker=tracker)
        label = labeller.label(sit)
        prediction = label.converged and first_pass_prediction(labeller, sit, tracker.reference_ahead_,
                                                               mode, label)
        if not prediction:
            raise _Unlabelled
        sit.info.update(tail=free_tail, decision_pass=1)
        first.append((sit, label))
        poses, wheels = prediction
        return poses, float(np.mean(wheels))

    for _attempt in range(100):
        try:
            second = sample_situation(rng, config, "paper", robot, settings or SETTINGS, tracker, first_pass)
        except _Unlabelled:
            continue
        second.info["decision_pass"] = 2
        return [first[-1], (second, labeller.label(second))]
    raise RuntimeError("no first-pass situation converged in 100 draws")  # pragma: no cover


def two_pass_stream(rng: np.random.Generator, config: PlannerConfig, labeller: Labeller,
                    robot: RobotParams | None = None, settings: SamplerSettings | None = None):
    """An endless stream of ``(situation, label)`` pairs from :func:`two_pass_samples`."""
    tracker = SituationTracker(config, reference_steps=2 * config.horizon - 1)
    while True:
        yield from two_pass_samples(rng, config, labeller, robot, settings, tracker)


class TwoPassGPC:
    """The paper's two-pass scheme with the GPC in place of the network: what a network that
    imitated the GPC's labels exactly would do (the scheme's own limit). Answers the Policy
    protocol; each decision labels fresh situations with ``labeller`` (multi-start, no warm
    start), as the dataset does.

    ``first_pass``: ``"rollout"`` (as the deployed policy: the obstacle-free answer applied
    step by step over H samples, each with the desired poses ahead of it) or ``"plan"`` (the
    GPC's obstacle-free open-loop plan). ``safety_distance_m``: the clearance below which the
    second pass runs (the deployed policy's default)."""

    def __init__(self, labeller: Labeller, first_pass: str = "rollout", safety_distance_m: float = 1.0):
        if first_pass not in ("rollout", "plan"):
            raise ValueError(f"first_pass must be 'rollout' or 'plan', got {first_pass!r}")
        self.labeller, self.first_pass, self.safety_distance_m = labeller, first_pass, float(safety_distance_m)
        self.config, self.robot = labeller.config, labeller.robot
        self.sample_time_s = self.config.sample_time_s
        self.tracker = SituationTracker(self.config, reference_steps=2 * self.config.horizon - 1)
        self.counters = {"decisions": 0, "second_pass": 0}

    def reset(self) -> None:
        self.tracker.reset()
        self.counters = {"decisions": 0, "second_pass": 0}

    def predict(self, situation: Situation, ref_ahead: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The first pass: desired poses at steps 0..H and the wheel speeds (H, 2)."""
        return first_pass_prediction(self.labeller, situation, ref_ahead, self.first_pass)

    def decide(self, obs: Observation) -> ControlDecision:
        situation = self.tracker.update(obs)
        self.counters["decisions"] += 1
        poses, wheels = self.predict(situation, self.tracker.reference_ahead_)
        clearance = min((float(np.min(np.hypot(*(t.means_m - poses[1:, :2]).T))) - self.robot.radius_m - t.radius_m
                         for t in situation.tracks), default=np.inf)
        if clearance >= self.safety_distance_m:
            return ControlDecision(float(wheels[0, 0]), float(wheels[0, 1]), False, "pass 1: path clear")
        self.counters["second_pass"] += 1
        # the second pass's situation as the dataset draws it: the prediction's mean speed
        # is the speed of its initial guesses
        label = self.labeller.label(replace(situation.with_reference(poses), ref_speed_mps=float(np.mean(wheels))))
        if not label.converged:
            return ControlDecision(float(wheels[0, 0]), float(wheels[0, 1]), True, "pass 2 did not converge")
        return ControlDecision(float(label.wheels_mps[0]), float(label.wheels_mps[1]), False, "pass 2: avoiding")
