"""gpcnav's controllers as navground behaviours: ``GPC`` (the planner behind its check layer)
and ``GPCNetwork`` (the shipped network behind its planner-free check).

navground's tools find them through the package's ``navground_behaviors`` entry points
(``navground.core.load_plugins()``, which ``navground_py`` calls at start), so an experiment
or scenario file selects them by name::

    behavior:
      type: GPC            # or GPCNetwork
      optimal_speed: 0.4   # the reference speed (m/s)
      preset: improved     # the planner preset (paper | improved)

What a behaviour does each time navground asks it for a command (docs/navground.md):

1. navground's target becomes the reference the controller follows: the straight line from
   where the robot is when the target is set to the target's point, or the target's path,
   at navground's ``optimal_speed`` (a target with a direction and no point, navground's
   ``Direction`` task: a long line that way); a new target, or the robot moved by the world
   (navground's periodic lattice), restarts the controller on a new reference
   (:mod:`gpcnav.navground_state`);
2. at the controller's own sample time (the preset's, 0.5 s for ``improved``) it is told
   navground's state: the robot's pose and the wheel speeds it drives, the neighbours'
   positions (with ids that last, :class:`~gpcnav.navground_state.NeighbourTracks`; the
   controller's own filters estimate their velocities, as in gpcnav's simulator), the
   static discs and line segments; between decisions the last wheel speeds are held, so
   navground may step at any period (the sample time is best a multiple of navground's step,
   and the agent's ``control_period`` left at 0);
3. the wheel speeds, within the acceleration limit (``max_wheel_acceleration``) as gpcnav's
   robot applies them, become navground's command through the agent's two-wheel kinematics
   (``2WDiff`` or ``2WDiffDyn``: the wheel base is its ``wheel_axis``, the wheel limit its
   ``max_speed``, the radius the agent's). gpcnav's robot drives backwards as well as
   forwards, and its planner uses that (to back away, or to reverse to a target behind it);
   navground's two-wheel kinematics forbid driving backwards by default, so the behaviour
   refuses kinematics whose ``max_backward_speed`` is below the wheel limit (a robot held
   still by its kinematics whenever the planner reverses would be measured, not the planner).

Without a target, or once navground finds it satisfied, the robot brakes to a stop within
the acceleration limit. navground's ``safety_margin`` and ``horizon`` are not used: the
preset's margins and the check layer keep the clearance.

Importing this module imports navground's core and the numpy-only parts of gpcnav; CasADi
and onnxruntime load when a behaviour makes its controller (navground's ``prepare``, or the
first command).
"""
from __future__ import annotations

import math
import warnings
from pathlib import Path

from navground import core

from casadi_gpc.config import PRESETS  # settings only: no solver, no network
from casadi_gpc.robot import RobotParams, RobotState, brake_wheels
from casadi_gpc.types import Observation

from .navground_state import NeighbourTracks, reference_to_target, static_obstacles, target_key, walls

__all__ = ["GPCBehavior", "GPCNetworkBehavior", "WHEELED_KINEMATICS"]

WHEELED_KINEMATICS = ("2WDiff", "2WDiffDyn")
"""navground's kinematics a gpcnav controller can drive (a two-wheel differential drive)."""

TELEPORT_M = 0.5
"""How much farther than its wheels take it in a step a robot must have moved to count as moved by the
world (navground's periodic lattice), which restarts the controller where it is."""


def _one_of_the_presets(schema: dict) -> None:
    """The preset's JSON schema (``navground_py schema``, ``validate``): one of the presets' names."""
    schema["enum"] = list(PRESETS)


def _from_float32(value) -> float:
    """A length or speed navground stores in single precision, as written in its file
    (0.35, not 0.3499999940395355): a network checks the robot it was trained for exactly."""
    return round(float(value), 6)


class GPCBehavior(core.Behavior, name="GPC"):
    """The GPC planner behind its check layer (gpcnav's controller ``gpc``), as a navground
    behaviour (see the module's documentation).

    *Registered properties*: ``preset`` [str], ``max_wheel_acceleration`` [float].

    *State*: :py:class:`navground.core.GeometricState`.
    """

    controller_name = "gpc"
    """The name of the controller in :data:`gpcnav.controllers.REGISTRY`."""

    def __init__(self, kinematics: core.Kinematics | None = None, radius: float = 0.0):
        core.Behavior.__init__(self, kinematics, radius)
        self._state = core.GeometricState()
        self._preset = "improved"
        self._max_wheel_acceleration = RobotParams().max_wheel_accel_mps2
        self._controller = None
        self._with_walls = False
        self._robot: RobotParams | None = None
        self._neighbours = NeighbourTracks()
        self._clock_s = 0.0
        self._last_xy: tuple[float, float] | None = None
        self.late_decisions = 0
        """Decisions made later than due (navground's step does not divide the sample time), since
        :meth:`prepare`; the first is said once as a :class:`RuntimeWarning`."""
        self._reset_target()

    # --- navground properties --------------------------------------------------------
    @property
    @core.register("improved", "The planner preset (paper | improved)", _one_of_the_presets)
    def preset(self) -> str:
        """The planner preset: its sample time, horizon, weights (CONTRACT.md, presets)."""
        return self._preset

    @preset.setter
    def preset(self, value: str) -> None:
        if str(value) not in PRESETS:  # refused when set (navground sets it as a run makes its world)
            raise ValueError(f"GPC behaviour: unknown preset {value!r} (choose from {', '.join(PRESETS)})")
        self._preset = str(value)
        self._controller = None

    @property
    @core.register(0.8, "Each wheel's acceleration limit [m/s^2]", core.schema.strict_positive)
    def max_wheel_acceleration(self) -> float:
        """Each wheel's acceleration limit (m/s^2; the contract's robot: 0.8)."""
        return self._max_wheel_acceleration

    @max_wheel_acceleration.setter
    def max_wheel_acceleration(self, value: float) -> None:
        value = float(value)
        if not (math.isfinite(value) and value > 0.0):  # (the schema says so, but navground does not check on set)
            raise ValueError(f"GPC behaviour: max_wheel_acceleration must be a positive number of m/s^2, got {value!r}")
        self._max_wheel_acceleration = value
        self._controller = None

    def get_environment_state(self) -> core.GeometricState:
        """navground's geometric state: neighbours, static discs and line segments."""
        return self._state

    # --- the controller --------------------------------------------------------------
    def robot_params(self) -> RobotParams:
        """gpcnav's robot of this agent: the kinematics' wheel axis and speed limit, the
        agent's radius, :attr:`max_wheel_acceleration`."""
        kin = self.kinematics
        if kin is None or kin.type not in WHEELED_KINEMATICS:
            raise ValueError(f"navground behaviour {self._type}: the agent's kinematics must be one of "
                             f"{', '.join(WHEELED_KINEMATICS)}, got {kin.type if kin is not None else None}")
        v_max = float(kin.max_speed)
        if not (math.isfinite(v_max) and v_max > 0.0):
            raise ValueError(f"navground behaviour {self._type}: set the kinematics' max_speed (the wheel limit, "
                             f"m/s), got {v_max}")
        for name in ("max_forward_speed", "max_backward_speed"):
            if kin.has(name) and float(kin.get(name)) < _from_float32(v_max):
                raise ValueError(f"navground behaviour {self._type}: gpcnav's robot drives both ways at the wheel "
                                 f"limit, the kinematics' {name} is {float(kin.get(name)):g} m/s (set it to "
                                 f"{_from_float32(v_max):g} or more)")
        if not self.radius > 0.0:
            raise ValueError(f"navground behaviour {self._type}: set the agent's radius (m)")
        return RobotParams(wheel_base_m=_from_float32(kin.get("wheel_axis")), radius_m=_from_float32(self.radius),
                           max_wheel_speed_mps=_from_float32(v_max),
                           max_wheel_accel_mps2=self._max_wheel_acceleration)

    def controller_spec(self):
        """The :class:`gpcnav.controllers.ControllerSpec` this behaviour runs."""
        from .controllers import ControllerSpec
        return ControllerSpec(self.controller_name)

    def make_controller(self, with_walls: bool = False):
        """The controller, made now (CasADi or onnxruntime load here) for this agent's robot;
        ``with_walls``: its planner with wall-segment slots (:data:`casadi_gpc.config.WALL_SLOTS`),
        for a world with line obstacles."""
        from casadi_gpc.config import preset
        from .controllers import make
        from .errors import UsageError
        self._robot = self.robot_params()
        self._with_walls = bool(with_walls)
        config = preset(self._preset).for_walls(self._with_walls)
        try:
            self._controller = make(self.controller_spec(), config, self._robot)
        except UsageError as exc:  # (a model for another robot: the agent's size, its wheels), said as the others are
            raise ValueError(f"navground behaviour {self._type}: {exc}") from None
        self._reset_target()
        return self._controller

    @property
    def controller(self):
        """The controller behind the behaviour (made on first use)."""
        if self._controller is None:
            self.make_controller()
        return self._controller

    def prepare(self) -> None:
        """navground's hook before a run: the controller is made here, not in the run."""
        self.make_controller()
        self._neighbours.reset()
        self._clock_s = 0.0
        self._last_xy = None
        self.late_decisions = 0

    # --- one command -----------------------------------------------------------------
    def _reset_target(self) -> None:
        self._target_key = self._reference = None
        self._reference_start_s = 0.0
        self._next_decision_s = 0.0
        self._wheels: tuple[float, float] | None = None  # (right, left) held between decisions
        self.last_decision = None
        """The controller's last :class:`~casadi_gpc.types.ControlDecision`."""

    def _follow(self, now_s: float) -> None:
        """Restart the controller on a new reference when navground's target changed."""
        key = target_key(self.target) if self.target.valid else None
        if key == self._target_key:
            return
        self._target_key = key
        self._reference = None if key is None else reference_to_target(self.target, self.position,
                                                                        float(self.optimal_speed))
        self._reference_start_s = self._next_decision_s = now_s
        self.controller.reset()

    def _moved_by_the_world(self, dt_s: float) -> None:
        """A robot farther from where it was a step ago than its wheels take it was moved by the world
        (navground's periodic lattice, as in its ``Corridor``: the agent wraps from one end to the other):
        the controller restarts from where it is now, as on a new target (its reference, clock and
        filters: the neighbours jumped with it)."""
        xy = (float(self.position[0]), float(self.position[1]))
        last, self._last_xy = self._last_xy, xy
        if last is not None and math.dist(xy, last) > self._robot.max_wheel_speed_mps * dt_s + TELEPORT_M:
            self._target_key = None
            self._neighbours.reset()

    def _limited(self, right: float, left: float, current: tuple[float, float], dt_s: float) -> tuple[float, float]:
        """The wheel speeds as gpcnav's robot applies them: each within its acceleration
        limit over ``dt_s`` and the wheel limit."""
        r = self._robot
        dv, v = r.max_wheel_accel_mps2 * dt_s, r.max_wheel_speed_mps
        return (min(v, max(-v, min(current[0] + dv, max(current[0] - dv, right)))),
                min(v, max(-v, min(current[1] + dv, max(current[1] - dv, left)))))

    def compute_cmd_internal(self, time_step: float) -> core.Twist2:
        """navground's step: a decision when one is due, else the held wheel speeds."""
        controller = self.controller
        dt = float(time_step)
        now = self._clock_s
        self._clock_s += dt
        self._moved_by_the_world(dt)
        moving = self._neighbours.update(self._state.neighbors, dt)
        lines = walls(self._state.line_obstacles)
        if lines and not self._with_walls:  # a world with walls: the planner gets its wall slots, once
            self.make_controller(with_walls=True)
            controller = self._controller
        self._follow(now)
        left_now, right_now = (float(w) for w in self.actuated_wheel_speeds)
        current = (right_now, left_now)
        if self._reference is None or self.check_if_target_satisfied():
            self._wheels = brake_wheels(*current, self._robot.max_wheel_accel_mps2 * dt)
        elif now >= self._next_decision_s - 1e-9:
            T = controller.sample_time_s
            x, y = (float(c) for c in self.position)
            obs = Observation(now - self._reference_start_s, RobotState(x, y, float(self.orientation), *current),
                              self._reference, moving,
                              static_obstacles(self._state.static_obstacles), lines)
            self.last_decision = d = controller.decide(obs)
            self._wheels = self._limited(d.v_right_mps, d.v_left_mps, current, T)
            # navground's step does not divide T: late (by more than its float32 steps' rounding), said once
            if now > self._next_decision_s + 1e-3 * dt:
                self.late_decisions += 1
                if self.late_decisions == 1:
                    warnings.warn(f"gpcnav {type(self).__name__}: navground's time step {dt:g} s does not divide the "
                                  f"controller's sample time {T:g} s: a decision came {now - self._next_decision_s:.3g}"
                                  f" s late, and others will (counted in late_decisions; pick a step that divides "
                                  f"it)", RuntimeWarning, stacklevel=2)
            while self._next_decision_s <= now + 1e-9:
                self._next_decision_s += T
        right, left = self._wheels if self._wheels is not None else (0.0, 0.0)
        return self.twist_from_wheel_speeds([left, right])


class GPCNetworkBehavior(GPCBehavior, name="GPCNetwork"):
    """The network (gpcnav's controller ``nn``, as ``--controller nn`` runs it) behind its
    planner-free check (shield mode ``on``: the check layer falls back on its own searched way
    out, no planner on standby, so no CasADi), as a navground behaviour.

    *Registered properties*: ``preset`` [str], ``max_wheel_acceleration`` [float],
    ``model`` [str], ``walls_model`` [str], ``crowd_model`` [str].

    *State*: :py:class:`navground.core.GeometricState`.
    """

    controller_name = "nn"

    # navground registers the properties a class itself declares, not those it inherits
    preset = GPCBehavior.preset
    max_wheel_acceleration = GPCBehavior.max_wheel_acceleration

    def __init__(self, kinematics: core.Kinematics | None = None, radius: float = 0.0):
        GPCBehavior.__init__(self, kinematics, radius)
        self._model = ""
        self._walls_model = ""
        self._crowd_model = ""

    @property
    @core.register("", "The ONNX model's path (empty: the one shipped for the preset)")
    def model(self) -> str:
        """The ONNX model file (a path, relative to the current folder; empty: the model
        shipped for :attr:`preset`)."""
        return self._model

    @model.setter
    def model(self, value: str) -> None:
        self._model = str(value)
        self._controller = None

    @property
    @core.register("", "The walls network's path (empty: the one shipped for the preset), as --walls-model")
    def walls_model(self) -> str:
        """The walls network's ONNX file, which answers where a wall is within 4 m (a path, relative to the
        current folder; empty: the one shipped for :attr:`preset`; ``--walls-model`` of the command line)."""
        return self._walls_model

    @walls_model.setter
    def walls_model(self, value: str) -> None:
        self._walls_model = str(value)
        self._controller = None

    @property
    @core.register("", "The crowd network's path (empty: the one shipped for the preset), as --crowd-model")
    def crowd_model(self) -> str:
        """The crowd network's ONNX file, which answers where the model cannot hold the obstacles in range
        (a path as :attr:`walls_model`; empty: the one shipped for :attr:`preset`)."""
        return self._crowd_model

    @crowd_model.setter
    def crowd_model(self, value: str) -> None:
        self._crowd_model = str(value)
        self._controller = None

    def controller_spec(self):
        from .controllers import ControllerSpec
        return ControllerSpec("nn", Path(self._model) if self._model else None, shield="on",
                              walls_model=Path(self._walls_model) if self._walls_model else None,
                              crowd_model=Path(self._crowd_model) if self._crowd_model else None)
