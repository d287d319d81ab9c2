"""``gpcnav/Navigation-v0``: gpcnav's episodes as a Gymnasium environment (the ``gym`` extra).

Built on :class:`scenarios.simulator.Episode`, so an agent drives exactly the robot, the
movers, the sensor and the outcome rules the controllers are evaluated with.

Making it::

    import gymnasium
    env = gymnasium.make("gpcnav:gpcnav/Navigation-v0")     # the default scene, no other import
    env = gymnasium.make("gpcnav/Navigation-v0", suite="circle-crossing", movers=5)  # after import gpcnav

The id is registered when the package ``gpcnav`` is imported (:func:`gpcnav.register_envs`,
Gymnasium's convention since 1.0); ``gymnasium.make("gpcnav:...")`` imports the package
first, so it needs no other import (docs/gym.md).

Keyword arguments (at most one of ``scenario`` and ``suite``; with neither, the default scene:
:data:`DEFAULT_SUITE`, 5 ORCA walkers, a new episode of the suite at every reset):

- ``scenario=PATH``: a scenario file; every reset runs it, with the sensing noise seeded from
  the environment's generator (``reset(seed=...)`` reproduces it);
- ``suite=NAME`` (``random``, ``random-multi``, ``encounters``, ``circle-crossing``,
  ``square-crossing``, and the buildings ``corridor``, ``doorway``, ``corner``) with ``movers``
  (default 5) and ``behaviour`` (default ``orca``) for the crowd and building suites, ``suite_seed`` (default 0: which suite) and ``count`` (None: each reset draws
  an episode index from [0, 2^31); N: from [0, N), a fixed set of N episodes);
  ``reset(options={"index": i})`` runs episode ``i`` of the suite;
- ``preset`` (default ``improved``): its sample time is the environment's step, unless
  ``sample_time_s`` is given;
- ``expert=NAME``: a controller of the registry (``gpc``, ``orca``, ...) whose answer to every
  observation is put in ``info["expert_action"]`` (for imitation); None by default. Where an
  episode's scenario has walls, the expert is made with the preset's wall slots
  (:meth:`casadi_gpc.config.PlannerConfig.for_walls`, as the command line does), so the GPC
  and MPPI plan with the walls; navground's peers take them as line obstacles.

Walls: the robot collides with them as in the simulator (``terminated``), ``clearance_m``
counts them, and ``env.unwrapped.observation.walls`` holds them (the Policy protocol's
observation); the observation vector does not (the contract asks for no walls there, and
:class:`ObservationLayout` is the movers' layout the networks were trained on).

Action: the two wheel speeds ``[v_right, v_left]`` (m/s, within the wheel limit); the robot
applies them as the simulator does, within its acceleration limit. ``terminated``: the goal
reached or a collision; ``truncated``: the scenario's time limit. ``info``: ``outcome``
(``running``, ``reached_goal``, ``collided``, ``timed_out``), ``clearance_m`` (the smallest
gap between the robot's disc and any obstacle's disc or wall now, true positions), ``min_clearance_m`` (the smallest over
the episode so far, sub-sampled like the collision check; both ``inf`` while there is nothing to keep clear
of, where the JSON documents write 1e9 m), ``t_s``, ``scenario``.
``clearance_m`` and ``min_clearance_m`` count the walls as well. ``env.unwrapped.observation``
is what a controller of the Policy protocol is told at the same instant (a :class:`casadi_gpc.types.Observation`), so any of them can drive the environment.

The observation vector and the reward are :class:`ObservationLayout` and
:class:`RewardSettings` (documented field by field).
"""
from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
from gymnasium import spaces
from gymnasium.core import Env

from casadi_gpc.config import preset as preset_config
from casadi_gpc.estimation.ekf import EKFSettings
from scenarios.simulator import Episode
from casadi_gpc.estimation.tracking import TrackBank
from casadi_gpc.finite import finite_real
from casadi_gpc.types import ControlDecision, Observation
from nn_export.runtime.features import wrap_pi

from . import ENV_ID, register_envs
from .errors import MIN_SAMPLE_TIME_S, UsageError

__all__ = ["ENV_ID", "DEFAULT_SUITE", "NavigationEnv", "ObservationLayout", "RewardSettings", "register_envs"]

DEFAULT_SUITE = "circle-crossing"
"""The scene made with no keyword argument (tools that make environments by id alone):
CrowdNav's circle crossing with the suite's defaults (5 walkers, ORCA, suite seed 0)."""


@dataclass(frozen=True)
class ObservationLayout:
    """The observation: a fixed-size float32 vector, positions and velocities in the robot's
    frame (x forward, y to the left; m, m/s), in this order:

    1. ``v_right, v_left``: the wheel speeds driven now;
    2. the reference point now and ``reference_points - 1`` steps ahead (the nominal
       reference, at ``t + k T``): ``dx, dy`` each;
    3. ``heading_error``: the reference's heading minus the robot's, wrapped (rad);
    4. the goal (end of the path): ``dx, dy``; ``time_left_s``: until the reference point
       reaches it (0 after);
    5. the ``movers`` nearest moving obstacles, nearest first, as the EKF bank estimates them:
       ``dx, dy, vx, vy, radius, present`` each (an empty slot is all zero);
    6. the ``statics`` nearest static obstacles: ``dx, dy, radius, present`` each.
    """

    reference_points: int = 5
    """Reference points, now and ahead."""
    movers: int = 5
    """Moving-obstacle slots (the crowd suites' default count)."""
    statics: int = 3
    """Static-obstacle slots (random-multi has up to three)."""

    def __post_init__(self):
        for name, least in (("reference_points", 1), ("movers", 0), ("statics", 0)):
            v = getattr(self, name)  # (movers=-1 made a shorter vector, reference_points=0 an IndexError)
            if isinstance(v, bool) or not isinstance(v, numbers.Integral) or v < least:
                raise ValueError(f"ObservationLayout.{name} must be a whole number of at least {least}, got {v!r}")

    def names(self) -> list[str]:
        out = ["v_right", "v_left"]
        out += [f"ref{k}_{c}" for k in range(self.reference_points) for c in ("dx", "dy")]
        out += ["heading_error", "goal_dx", "goal_dy", "time_left_s"]
        out += [f"mover{j}_{c}" for j in range(self.movers) for c in ("dx", "dy", "vx", "vy", "radius", "present")]
        out += [f"static{j}_{c}" for j in range(self.statics) for c in ("dx", "dy", "radius", "present")]
        return out

    @property
    def size(self) -> int:
        return 6 + 2 * self.reference_points + 6 * self.movers + 4 * self.statics

    def bounds(self, max_wheel_speed_mps: float) -> tuple[np.ndarray, np.ndarray]:
        """``(low, high)`` of every entry: the wheel limit, +-pi for the heading error, 0..1
        for ``present``, and loose physical bounds elsewhere (1 km, 10 m/s, 10 m radii,
        100000 s). An observation beyond them is clipped into them, and counted
        (``info["clipped_observations"]``)."""
        v = max_wheel_speed_mps
        whole = {"v_right": (-v, v), "v_left": (-v, v), "heading_error": (-math.pi, math.pi),
                 "time_left_s": (0.0, 1.0e5)}
        suffix = {"dx": (-1.0e3, 1.0e3), "dy": (-1.0e3, 1.0e3), "vx": (-10.0, 10.0), "vy": (-10.0, 10.0),
                  "radius": (0.0, 10.0), "present": (0.0, 1.0)}
        pairs = [whole[n] if n in whole else suffix[n.rpartition("_")[2]] for n in self.names()]
        low, high = zip(*pairs)
        return np.array(low, dtype=np.float32), np.array(high, dtype=np.float32)


@dataclass(frozen=True)
class RewardSettings:
    """CrowdNav's reward (goal, collision, discomfort) and a progress term along the path."""

    goal: float = 1.0
    """On reaching the goal (CrowdNav: 1)."""
    collision: float = -0.25
    """On a collision (CrowdNav: -0.25)."""
    discomfort_distance_m: float = 0.2
    """Clearance to a mover below which each step is penalised (CrowdNav: 0.2 m)."""
    discomfort_weight: float = 0.5
    """The penalty per step: ``weight x (clearance - distance) x T`` (CrowdNav: 0.5)."""
    progress_per_m: float = 0.1
    """Reward per metre gained along the path (projection of the robot on it); 0 for
    CrowdNav's reward alone, which is sparse."""

    def __post_init__(self):
        for f in fields(self):  # (a NaN was taken, and every reward of its kind was NaN)
            v = getattr(self, f.name)
            if not finite_real(v):
                raise ValueError(f"RewardSettings.{f.name} must be a finite number, got {v!r}")


def observation_vector(obs: Observation, tracks: list, layout: ObservationLayout, sample_time_s: float) -> np.ndarray:
    """The :class:`ObservationLayout` vector of ``obs``; ``tracks`` are ``(x, y, vx, vy,
    radius)`` of the moving obstacles' estimates (world frame)."""
    r = obs.robot
    c, s = math.cos(r.heading_rad), math.sin(r.heading_rad)

    def rel(x, y):
        dx, dy = x - r.x_m, y - r.y_m
        return c * dx + s * dy, -s * dx + c * dy

    out = [r.v_right_mps, r.v_left_mps]
    ref = obs.reference
    poses = ref.pose_at_time(obs.t_s + sample_time_s * np.arange(layout.reference_points))
    for x, y, _ in poses:
        out += rel(x, y)
    out.append(float(wrap_pi(float(poses[0][2]) - r.heading_rad)))
    end = ref.end_pose
    out += rel(end[0], end[1])
    out.append(max(0.0, ref.duration_s - obs.t_s))
    near = sorted(tracks, key=lambda t: math.hypot(t[0] - r.x_m, t[1] - r.y_m))[: layout.movers]
    for x, y, vx, vy, radius in near:
        out += [*rel(x, y), c * vx + s * vy, -s * vx + c * vy, radius, 1.0]
    out += [0.0] * (6 * (layout.movers - len(near)))
    statics = sorted(obs.static, key=lambda o: math.hypot(o.position_m[0] - r.x_m, o.position_m[1] - r.y_m))
    for o in statics[: layout.statics]:
        out += [*rel(*o.position_m), o.radius_m, 1.0]
    out += [0.0] * (4 * (layout.statics - min(len(statics), layout.statics)))
    return np.asarray(out, dtype=np.float32)


class NavigationEnv(Env):
    """gpcnav's episodes as a Gymnasium environment (see the module's documentation)."""

    metadata = {"render_modes": []}

    def __init__(self, scenario: str | Path | None = None, suite: str | None = None, movers: int | None = None,
                 behaviour: str | None = None, suite_seed: int = 0, count: int | None = None, preset: str = "improved",
                 sample_time_s: float | None = None, expert: str | None = None,
                 layout: ObservationLayout = ObservationLayout(), reward: RewardSettings = RewardSettings(),
                 render_mode: str | None = None):
        if render_mode is not None:  # (gymnasium.make passes it when asked for one)
            raise ValueError(f"render_mode {render_mode!r}: this environment renders nothing (draw an episode with "
                             f"gpcnav simulate SCENARIO --plot FIG.png or --animate ANIM.gif)")
        if scenario is not None and suite is not None:
            raise ValueError("give scenario=PATH or suite=NAME, not both")
        if scenario is None and suite is None:
            suite = DEFAULT_SUITE
        self.config = preset_config(preset)
        self.sample_time_s = float(self.config.sample_time_s if sample_time_s is None else sample_time_s)
        if not (math.isfinite(self.sample_time_s) and self.sample_time_s >= MIN_SAMPLE_TIME_S):
            # (any positive step was taken: 1e-9 s made a 20 s episode twenty billion steps)
            raise ValueError(f"sample_time_s must be at least {MIN_SAMPLE_TIME_S} s, the command line's shortest, "
                             f"got {sample_time_s}")
        if expert is not None:  # a name of the registry, refused now rather than at the first reset
            from .controllers import check_controller_name
            check_controller_name(str(expert), "expert")
        self._file_scenario = None
        self.suite = None
        if scenario is not None:
            from scenarios import load_scenario
            given = [k for k, v in (("movers", movers), ("behaviour", behaviour), ("count", count)) if v is not None]
            if given or suite_seed:  # a suite's options: taken and ignored with a file
                raise ValueError(f"{', '.join(given + ['suite_seed'] * bool(suite_seed))}: options of a suite, not of "
                                 f"scenario={scenario!s} (a file runs as it is)")
            self._file_scenario = load_scenario(scenario)
        else:
            from scenarios import Suite
            from scenarios.suites import check_suite_options
            if count is not None and (isinstance(count, bool) or not isinstance(count, numbers.Integral)
                                      or count < 1):  # (2.5 was taken: the draws' set was [0, 2.5))
                raise ValueError(f"count must be a whole number of episodes, at least 1, got {count!r}")
            # (movers=True ran one mover, suite_seed=True suite 1; suite_seed "a" was a TypeError naming neither)
            for key, value in (("movers", movers), ("suite_seed", suite_seed)):
                if value is not None and (isinstance(value, bool) or not isinstance(value, numbers.Integral)
                                          or value < 0):
                    raise ValueError(f"{key} must be a whole number, 0 or more, got {value!r}")
            check_suite_options(suite, movers, behaviour)
            self.suite = Suite(suite, count or 1, suite_seed, 5 if movers is None else movers, behaviour)
        self.count = count
        for key, value, kind in (("layout", layout, ObservationLayout), ("reward", reward, RewardSettings)):
            if not isinstance(value, kind):  # (None or a dict failed at the first reset or step, naming neither)
                raise ValueError(f"{key} must be a gpcnav.gym_env.{kind.__name__}, got {value!r}")
        self.layout, self.reward_settings = layout, reward
        self.expert_name = expert
        self._experts: dict = {}
        example = self._file_scenario or self.suite.scenario(0)
        vmax = example.robot.max_wheel_speed_mps
        self.action_space = spaces.Box(-vmax, vmax, shape=(2,), dtype=np.float32)
        low, high = layout.bounds(vmax)
        self.observation_space = spaces.Box(low, high, dtype=np.float32)
        self.episode: Episode | None = None
        self.observation: Observation | None = None
        """What a controller is told now (the Policy protocol's observation)."""
        self.expert = None
        """The controller whose answers go into ``info["expert_action"]`` this episode (None
        without ``expert``): made for the episode's robot, and with the preset's wall slots
        where its scenario has walls."""
        if expert is not None:
            self._check_expert(str(expert), example)

    def _check_expert(self, name: str, scenario) -> None:
        """Refuse now, rather than at the first reset, an expert that cannot drive ``scenario``'s
        robot (the network and a robot larger than it was trained for, or other wheels) or that
        decides at another sample time than the environment steps. The planner's readers
        (``gpc``, ``mppi``) drive any robot at the preset's step: read without building them; the
        others (the peers, the baselines, the network, a user's class) are made once to ask."""
        from .controllers import PLANNER_READERS, ControllerSpec, make
        if name in PLANNER_READERS:
            step = self.config.sample_time_s
        else:
            try:
                step = make(ControllerSpec(name), self.config.for_walls(bool(scenario.walls)),
                            scenario.robot).sample_time_s
            except (UsageError, ValueError) as exc:
                raise ValueError(f"expert {name!r} on {scenario.source or scenario.name}: {exc}") from None
        if not math.isclose(step, self.sample_time_s):
            raise ValueError(f"expert {name!r} decides every {step} s, the environment steps every "
                             f"{self.sample_time_s} s")

    # --- episodes ----------------------------------------------------------------------
    def _next_scenario(self, options: dict | None):
        unknown = sorted(map(str, set(options or {}) - {"index"}))
        if unknown:  # (a misspelt "idx" was taken and ignored: a random episode ran)
            raise ValueError(f"options {', '.join(map(repr, unknown))}: not an option of reset (it reads only index)")
        if self._file_scenario is not None:
            if (options or {}).get("index") is not None:  # (it was taken and ignored)
                source = self._file_scenario.source or self._file_scenario.name
                raise ValueError(f"options index: episodes of a suite; scenario={source} runs its one episode")
            return self._file_scenario.with_seed(int(self.np_random.integers(0, 2 ** 31 - 1)))
        index = (options or {}).get("index")
        if index is None:
            index = int(self.np_random.integers(0, self.count if self.count else 2 ** 31 - 1))
        elif isinstance(index, bool) or not isinstance(index, numbers.Integral):  # (2.7 ran episode 2, True 1)
            raise ValueError(f"options index {index!r}: an episode of the suite is a whole number, 0 or more")
        elif index < 0:  # (any other: episode ``index`` of the suite, ``count`` or not: the draws' set only)
            raise ValueError(f"options index {index}: an episode of the suite is 0 or more")
        return self.suite.scenario(int(index))

    def _expert(self, scenario):
        if self.expert_name is None:
            return None
        key = (scenario.robot, bool(scenario.walls))
        if key not in self._experts:
            from .controllers import ControllerSpec, make
            expert = make(ControllerSpec(self.expert_name), self.config.for_walls(bool(scenario.walls)),
                          scenario.robot)
            if not math.isclose(expert.sample_time_s, self.sample_time_s):
                raise ValueError(f"expert {self.expert_name!r} decides every {expert.sample_time_s} s, the "
                                 f"environment steps every {self.sample_time_s} s")
            self._experts[key] = expert
        return self._experts[key]

    def _observe(self) -> tuple[np.ndarray, dict]:
        ep = self.episode
        self.observation = obs = ep.observation()
        tracks = []
        for m, ekf in self._bank.step(obs.moving, obs.t_s):
            x, y = ekf.state_[:2]
            vel = ekf.velocity_mps
            tracks.append((x, y, *vel, m.radius_m))
        vec = observation_vector(obs, tracks, self.layout, self.sample_time_s)
        space = self.observation_space
        inside = np.clip(vec, space.low, space.high)
        if not np.array_equal(inside, vec):  # (a 15 m disc, a path over 1 km: outside the space, unsaid)
            self._clipped_observations += 1
            vec = inside
        # t_s: once ended, when it ended (duration_s, a contact): the next sample's 10.5 s in a 10.25 s run
        info = {"outcome": ep.log.outcome if ep.done else "running", "t_s": ep.log.end_time_s if ep.done else ep.t_s,
                "clearance_m": self._clearance_now(), "min_clearance_m": float(ep.log.min_clearance_m),
                "scenario": ep.scenario.name, **self._actions, "clipped_observations": self._clipped_observations}
        expert = self.expert
        if expert is not None and not ep.done:
            d = expert.decide(obs)
            info["expert_action"] = np.array([d.v_right_mps, d.v_left_mps], dtype=np.float32)
        return vec, info

    def _clearance_now(self) -> float:
        ep = self.episode
        sc = ep.scenario
        xy = np.asarray(ep.log.obstacle_xy[-1]).reshape(-1, 2)
        radii = np.array([m.radius_m for m in sc.moving] + [s.radius_m for s in sc.static])
        with np.errstate(invalid="ignore"):  # a track mover not in the scene is NaN: no gap
            gaps = np.hypot(*(xy - ep.state[:2]).T) - radii - sc.robot.radius_m
        walls = [float(w.distance_m(ep.state[None, :2])[0]) - sc.robot.radius_m for w in sc.walls]
        gaps = np.concatenate([gaps[np.isfinite(gaps)], walls])
        return float(gaps.min()) if gaps.size else math.inf

    def _progress_m(self) -> float:
        ep = self.episode
        self._s_m = ep.scenario.reference.project(ep.state[:2], self._s_m, window_m=1.0)
        return self._s_m

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        scenario = self._next_scenario(options)
        self.episode = Episode(scenario, self.sample_time_s, self.expert_name or "gym")
        self._bank = TrackBank(self.sample_time_s, EKFSettings().for_sample_time(self.sample_time_s))
        self._actions = {"clipped_actions": 0, "non_finite_actions": 0}
        self._clipped_observations = 0
        self._s_m = 0.0
        self._progress_m()
        self.expert = expert = self._expert(scenario)
        if expert is not None:
            expert.reset()
        return self._observe()

    def __deepcopy__(self, memo):
        """A copy that steps on as this environment would, independent of it (the episode's
        movers, sensor noise, filters and generator copied). An expert that holds what cannot be
        copied (the GPC's CasADi solver, the network's onnxruntime session, navground's social
        force) is a TypeError saying so: copied bare, the walkers failed with "cannot pickle
        'navground.core._navground.GeometricState' object" after a reset."""
        import copy
        new = object.__new__(type(self))
        memo[id(self)] = new
        for name, value in self.__dict__.items():
            try:
                new.__dict__[name] = copy.deepcopy(value, memo)
            except TypeError as exc:
                if name not in ("expert", "_experts"):
                    raise
                raise TypeError(f"NavigationEnv: expert {self.expert_name!r} cannot be copied ({exc}): make another "
                                f"environment with the same keywords and reset it with the same seed") from None
        return new

    def render(self):
        """Nothing: the environment has no render mode (Gymnasium's convention for
        ``render_mode=None``: no render is computed, None returned; the base class raised
        ``NotImplementedError`` at ``env.render()``). ``gpcnav simulate SCENARIO --plot`` /
        ``--animate`` draw an episode."""
        return None

    def step(self, action):
        if self.episode is None or self.episode.done:
            raise RuntimeError("call reset() first: the episode has ended")
        raw = np.asarray(action, dtype=float).reshape(2)
        vmax = self.episode.scenario.robot.max_wheel_speed_mps
        a = np.clip(raw, -vmax, vmax)
        if not np.isfinite(raw).all():  # braked for by the simulator (its events count it too)
            self._actions["non_finite_actions"] += 1
        elif (np.abs(raw) > float(np.float32(vmax))).any():  # beyond the wheel limit: applied at the limit
            # (the action space's float32 bound, 0.800000012 for 0.8, is the limit, not beyond it: an action
            # at the space's high, or the float32 expert_action at the limit, was counted as clipped)
            self._actions["clipped_actions"] += 1
        before = self._s_m
        outcome = self.episode.step(ControlDecision(float(a[0]), float(a[1])))
        rs = self.reward_settings
        reward = rs.progress_per_m * (self._progress_m() - before)
        mover_gap = self.episode.log.mover_clearance_m[-1]
        if mover_gap < rs.discomfort_distance_m and outcome != "collided":
            reward += rs.discomfort_weight * (mover_gap - rs.discomfort_distance_m) * self.sample_time_s
        if outcome == "reached_goal":
            reward += rs.goal
        elif outcome == "collided":
            reward += rs.collision
        vec, info = self._observe()
        return vec, float(reward), outcome in ("reached_goal", "collided"), outcome == "timed_out", info
