"""The deployed controller: the ONNX network run with onnxruntime (numpy, onnxruntime and, for the
obstacle forecasts and the check, numba only).

:class:`OnnxPolicy` answers ``decide(observation) -> ControlDecision`` like the GPC controller, with
the same obstacle EKF and reference clock (:class:`nn_export.runtime.tracker.SituationTracker`) and
the same features as the dataset; at a finished reference's end it holds the robot still
(:mod:`nn_export.runtime.goal_hold`). It runs the paper's two-pass scheme (section 4):

1. predict the robot's next H poses with the network as if there were no obstacle: the network is
   rolled forward H steps with the robot model, each step's features computed from the predicted
   state and the desired poses ahead of it;
2. if that predicted path comes closer than ``safety_distance_m`` (clearance: centre distance
   minus both radii) to a predicted obstacle position at the same step (moving) or to a static
   obstacle, the predicted poses become the new desired trajectory and the network is run once
   more, now with the obstacles; otherwise the first control of the obstacle-free pass is applied.

``two_pass=False`` is the plain variant: one call with the obstacles and the real reference.

A plan network (``gpcnav train --target plan``) outputs the whole H-step sequence of wheel speeds:
its first step is the command, and the decision carries the plan (``planned_wheels_mps``), which
the check layer tests as a plan (:mod:`casadi_gpc.safety`, with the shifted previous plan as the
safe candidate). It runs one pass.

A model file is checked when it is loaded (:mod:`nn_export.runtime.model_file`), never at the first
decision; anything wrong is a one-line ``ValueError`` (``FileNotFoundError`` for a missing file).
"""
from __future__ import annotations

import hashlib
import json
import math
import time
from dataclasses import MISSING, fields
from itertools import repeat
from operator import sub
from pathlib import Path

import numpy as np

from casadi_gpc.config import DEFAULT_PRESET, preset as preset_config
from casadi_gpc.estimation.ekf import EKFSettings
from casadi_gpc.robot import RobotParams, robot_step_float
from casadi_gpc.types import ControlDecision, Observation, finite_real

from .features import RolloutFeatures, feature_values, feature_values_from
from .goal_hold import goal_hold
from .model_file import INPUT_NAME, OUTPUT_NAME, POLICY_FORMAT, _bind, _load_session, _validate, read_model_metadata
from .rollout import roll_out
from .set_slots import CrowdSlots
from .situation import Situation, reference_rows, straight_estimates
from .side_networks import CrowdNetwork, WallsNetwork
from .tracker import SituationTracker
from .wall_scan import map_rows, scan_rows, static_wall_rows

__all__ = ["OnnxPolicy", "MODELS_DIR", "shipped_model_path", "shipped_crowd_model_path", "shipped_walls_model_path",
           "SHIPPED", "read_model_metadata", "POLICY_FORMAT", "DEFAULT_SAFETY_DISTANCE_M"]

MODELS_DIR = Path(__file__).parents[1] / "models"
DEFAULT_SAFETY_DISTANCE_M = {"paper": 1.0, "improved": 1.0}
"""Clearance below which the second pass runs, per preset (measured: docs/nn-policy.md)."""


def shipped_model_path(preset: str) -> Path:
    """The model the package ships for ``preset`` (a name of no preset: its ValueError, not a missing file)."""
    return MODELS_DIR / f"{preset_config(preset).name}.onnx"


def shipped_crowd_model_path(preset: str) -> Path:
    """The set-layout network the package ships for ``preset``'s crowds (it may not exist)."""
    return MODELS_DIR / f"{preset}-crowd.onnx"


def shipped_walls_model_path(preset: str) -> Path:
    """The network that reads walls (``set-walls`` layout) the package ships for ``preset``
    (it may not exist)."""
    return MODELS_DIR / f"{preset}-walls.onnx"


TRACKED = ("missed_measurements", "outliers", "missed_samples", "ghosts", "manoeuvres")
SHIPPED = "shipped"
"""``OnnxPolicy(crowd_model=SHIPPED)``: the crowd network shipped for the preset, if any,
when the policy runs the model shipped for it."""


def _plan_decision(plan: np.ndarray, reason: str, forecasts) -> ControlDecision:
    """The decision of a plan network: the plan's first step, the plan with it."""
    return ControlDecision(float(plan[0, 0]), float(plan[0, 1]), False, reason, plan, forecasts=forecasts)


def _decision_maker(reason: str):
    """``make(vr, vl, forecasts)``: ``ControlDecision(vr, vl, False, reason, forecasts=forecasts)``,
    made by filling a new instance's fields in one go. The frozen dataclass's own
    ``__init__`` sets its ten fields one ``object.__setattr__`` at a time: 3-4 us on the
    2-core machine, a tenth of the one-pass decision (measured). The other fields are the
    class's defaults, taken from an instance the constructor made, and every default factory
    is called afresh for each decision (a field added to the class is covered alike; a test
    compares the two)."""
    if hasattr(ControlDecision, "__post_init__"):  # checks of its own: the constructor, always
        return lambda vr, vl, forecasts: ControlDecision(vr, vl, False, reason, forecasts=forecasts)
    proto = ControlDecision(0.0, 0.0, False, reason).__dict__
    factories = tuple((f.name, f.default_factory) for f in fields(ControlDecision) if f.default_factory is not MISSING)
    new = object.__new__
    if factories == (("info", dict),):  # the class as it is: its one factory written out

        def make(vr: float, vl: float, forecasts) -> ControlDecision:
            d = new(ControlDecision)
            values = d.__dict__
            values.update(proto)
            values["v_right_mps"], values["v_left_mps"], values["forecasts"], values["info"] = vr, vl, forecasts, {}
            return d

        return make

    def make_any(vr: float, vl: float, forecasts) -> ControlDecision:
        d = new(ControlDecision)
        values = d.__dict__
        values.update(proto)
        values["v_right_mps"], values["v_left_mps"], values["forecasts"] = vr, vl, forecasts
        for name, factory in factories:
            values[name] = factory()
        return d

    return make_any


class OnnxPolicy:
    """The network controller (see the module docstring).

    Parameters
    ----------
    model : path or None
        An ONNX file from ``gpcnav export``; None loads the model shipped for ``preset``.
    preset : str or None
        The planner preset the model must have been trained for (None: the model's own
        preset, or the default preset when ``model`` is None as well).
    robot : RobotParams, optional
        The robot it drives: the one the model was trained for, or one only smaller (it keeps
        the trained robot's distances: :func:`~nn_export.runtime.model_file.serves_robot`).
    two_pass : bool or None
        The paper's two-pass scheme (True) or one plain pass with the obstacles and the real
        reference (False); None (default): what the model file says (metadata
        ``decision_passes``, set by ``gpcnav export --passes``; 2 when absent).
    safety_distance_m : float, optional
        Clearance that triggers the second pass (default per preset,
        :data:`DEFAULT_SAFETY_DISTANCE_M`).
    ekf_settings : EKFSettings, optional
        The obstacle filter's noise levels (default as the GPC's).
    crowd_model : path, None or ``"shipped"``
        A network of the ``set`` layout (one pass) that answers, in place of ``model``,
        whenever more obstacles are in range than ``model``'s layout has slots for (a
        one-obstacle model among walkers). ``"shipped"`` (default): the crowd network shipped
        for the preset (:func:`shipped_crowd_model_path`) when ``model`` is the shipped one
        (None, or a file with its bytes) and its layout is not a set; None: never. Its
        decisions are counted (``crowd_network``).
    walls_model : path, None or ``"shipped"``
        A network of the ``set-walls`` layout (one pass) that answers, in place of the other
        two, whenever a wall of the map is within its scan's range of the robot.
        ``"shipped"`` (default): the one shipped for the preset
        (:func:`shipped_walls_model_path`) when ``model`` is the shipped one and reads no
        walls; None: never. Its decisions are counted (``walls_network``). A map without
        walls never hands a decision to it.
    check_forecast : ``"turn"``, ``"straight"`` or None
        The forecast of the tracks that each decision hands over (``forecasts``) for a check
        layer to judge it against: the filter's turning model, or straight on at the estimated
        speed and heading. None (default): the preset's planner's (``PlannerConfig.forecast``:
        straight in ``improved``, turning in ``paper``), so that the network's check judges as
        the GPC's does. The network's own features always read the turning forecast it was
        trained with. (The turning forecast's deviation at 6 s is metres for a walker seen a
        second or two; behind it the planner-free check stepped in at most decisions among
        real people: docs/nn-deploy.md, "The check judges on the planner's forecast".)
    statics_as_walls : bool
        Where the walls network answers, each static obstacle is drawn in its wall scan as the
        octagon round it (:func:`~nn_export.runtime.wall_scan.static_wall_rows`) and left out
        of its static slots, for its decision and its roll-out (default True). It was trained
        on buildings without static obstacles; a pillar reaches it as a range sensor would see
        it. Adopted by a rule on unseen cases (docs/buildings.md, "A pillar in a building":
        with a pillar in the three wall suites, 90 / 8 / 82 -> 105 / 4 / 71 reached / collided
        / timed out). A check layer judges against the discs themselves either way.
    compiled_set_networks : bool
        The crowd and walls networks' one-command pass compiled (numba) where it answers as
        onnxruntime does on probe rows at load (:mod:`nn_export.runtime.compiled_set`;
        ``model_info``'s ``crowd_model`` and ``walls_model`` say which ran, ``executor``): the
        deployable decision 10-15 % faster at the median. Default False: its answers differ from
        onnxruntime's in the last float32 bits, and among people who see the robot that grows into
        other episodes; judged by a rule on unseen cases it reached fewer goals and collided more
        (437 / 3 -> 429 / 6, docs/nn-deploy.md, "The set networks compiled"), so it is not the default.

    This is the bare network: deployed, it runs behind the safety check layer,
    ``casadi_gpc.safety.Shield(OnnxPolicy())`` (numpy and numba), which checks every
    command against the policy's own filters' estimates (each decision hands them over,
    forecast as ``check_forecast`` says: ``provides_forecasts``) and hands over to a fallback
    planner or a manoeuvre when it fails.
    """

    provides_forecasts = True
    """Each decision carries the track estimates it was made with (``forecasts``), forecast
    for the check as :attr:`check_forecast` says."""

    def __init__(self, model=None, preset: str | None = None, robot: RobotParams | None = None,
                 two_pass: bool | None = None, safety_distance_m: float | None = None,
                 ekf_settings: EKFSettings | None = None, crowd_model=SHIPPED, walls_model=SHIPPED,
                 check_forecast: str | None = None, statics_as_walls: bool = True, compiled_set_networks: bool = False):
        t0 = time.perf_counter()
        self.robot = robot or RobotParams()
        path = Path(model) if model is not None else shipped_model_path(preset or DEFAULT_PRESET)
        self.session, data = _load_session(path)
        meta = read_model_metadata(self.session, path)
        self.layout, self.config, self.steps = _validate(path, self.session, meta, preset, self.robot)
        self.sample_time_s = self.config.sample_time_s
        self.horizon = self.config.horizon
        if self.steps > 1:  # a plan network: one pass, its plan checked as a plan
            if two_pass:
                raise ValueError(f"{path}: a plan network runs one pass, not the paper's two")
            two_pass = False
        if two_pass is None:
            passes = meta.get("decision_passes", "2")
            if passes not in ("1", "2"):
                raise ValueError(f"{path}: metadata decision_passes is {passes!r}, expected '1' or '2'")
            two_pass = passes == "2"
        self.two_pass = bool(two_pass)
        d = DEFAULT_SAFETY_DISTANCE_M[self.config.name] if safety_distance_m is None else safety_distance_m
        if not (finite_real(d) and d >= 0):  # (-1 was taken; "abc" failed inside float(), "0.3" passed)
            raise ValueError(f"safety_distance_m must be a finite number, not negative, got {safety_distance_m!r}")
        self.safety_distance_m = float(d)
        # two passes need the desired poses at steps 0..2H-1 (the window of roll-out step j is j..j+H)
        self.tracker = SituationTracker(self.config, ekf_settings,
                                        reference_steps=2 * self.horizon - 1 if self.two_pass else None)
        self.check_forecast = self.config.forecast if check_forecast is None else str(check_forecast)
        if self.check_forecast not in ("turn", "straight"):
            raise ValueError(f"check_forecast must be 'turn' or 'straight', got {check_forecast!r}")
        self._straight_check = self.check_forecast == "straight"
        self._x, self._y, self._write, self._binding, self._run = _bind(self.session, self.layout.size, path,
                                                                        2 * self.steps)
        self._x1, self._y1 = self._x[0], self._y[0]  # views of the bound rows
        self._last_values: list[float] = [0.0] * self.layout.size  # see _f64
        self.model_info = {
            "path": str(path), "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest(),
            "preset": meta["preset"], "feature_layout": self.layout.name, "feature_layout_version": self.layout.version,
            "n_features": self.layout.size, "horizon": self.horizon, "sample_time_s": self.sample_time_s,
            "hidden": int(meta.get("hidden", 0)) or None, "layers": int(meta.get("layers", 1)),
            "dataset": json.loads(meta["dataset"]), "validation_rmse_mps": float(meta["validation_rmse_mps"]),
            "two_pass": self.two_pass, "safety_distance_m": self.safety_distance_m}
        # the shipped model by its bytes, wherever the file is (named with --model, or navground's
        # ``model``, it was left without its crowd and walls networks and froze at a pillar)
        shipped_main = shipped_model_path(self.config.name)
        is_shipped = model is None or (shipped_main.is_file() and shipped_main.read_bytes() == data)
        self._one_pass_decision = _decision_maker("one pass")
        self._crowd_decision = _decision_maker("one pass: crowd network")
        if isinstance(crowd_model, str) and crowd_model == SHIPPED:
            shipped = shipped_crowd_model_path(self.config.name)
            crowd_model = shipped if is_shipped and not self.layout.is_set and shipped.is_file() else None
        self._crowd = None if crowd_model is None else CrowdNetwork(Path(crowd_model), self.config.name, self.robot,
                                                                      self.layout, compiled_set_networks)
        if self._crowd is not None:
            self.model_info["crowd_model"] = self._crowd.info
        if isinstance(walls_model, str) and walls_model == SHIPPED:
            shipped = shipped_walls_model_path(self.config.name)
            walls_model = shipped if is_shipped and not self.layout.wall_sectors and shipped.is_file() else None
        self._walls = None if walls_model is None else WallsNetwork(Path(walls_model), self.config.name, self.robot,
                                                                      self.layout, compiled_set_networks)
        self._walls_decision = _decision_maker("one pass: walls network")
        self.statics_as_walls = bool(statics_as_walls)
        self._static_key, self._static_rows = None, None  # the static discs as wall pieces, made once per set
        if self._walls is not None:
            self.model_info["walls_model"] = self._walls.info
        self.outputs_plans = self.steps > 1 or any(n is not None and n.steps > 1 for n in (self._crowd, self._walls))
        """Whether a decision may carry the network's own plan (check it as a plan, keep the
        shifted previous one: ``casadi_gpc.safety.CheckSettings(previous_plan=True)``)."""
        self.model_info["output"] = "plan" if self.steps > 1 else "command"
        self.model_info["check_forecast"] = self.check_forecast
        self.load_time_s = time.perf_counter() - t0
        self.reset()

    # --- state -----------------------------------------------------------------------
    def reset(self) -> None:
        self.tracker.reset()
        self._counters = {"decisions": 0, "second_pass": 0, "crowd_network": 0, "walls_network": 0, "goal_holds": 0,
                          "feature_report": {}}
        self._last = None
        self._last_slots = None  # the last decision's CrowdSlots, where it made them (its roll-out reads them)

    @property
    def counters(self) -> dict:
        """Decisions, second passes, the feature report, and the tracker's missed measurements and samples,
        gated outliers, ghosts, manoeuvres and dropped tracks (movers no longer listed, once one is), current
        when read (a track seen once is counted by the safety check layer, as shield_unestimated_tracks)."""
        tracked, counters = self.tracker.counters, self._counters
        counters.update((k, tracked[k]) for k in (*TRACKED, "dropped_tracks") if k in tracked)
        return counters

    # --- the network -----------------------------------------------------------------
    @property
    def _f64(self) -> np.ndarray:
        """The last network input made from a whole situation (one pass, pass 2), in float64."""
        return np.array(self._last_values)

    def _net_values(self, values: list[float]) -> tuple[float, float]:
        """One network call on these feature values (preallocated buffers): its first command;
        the input kept (:attr:`_f64`)."""
        self._last_values = values
        return self._net_answer(values)

    def _net_answer(self, values: list[float]) -> tuple[float, float]:
        """:meth:`_net_values` without keeping the input (a roll-out's calls)."""
        self._write(*values)
        self._run()
        vr, vl = self._y1[:2].tolist()
        return vr, vl

    def _net_plan(self, values: list[float]) -> np.ndarray:
        """One call of a plan network on these feature values: its (H, 2) plan, float64."""
        self._net_values(values)
        return self._y.reshape(self.steps, 2).astype(float)

    def _net(self, situation: Situation) -> tuple[float, float]:
        """One network call on ``situation``'s features."""
        return self._net_values(feature_values(self.layout, situation, self._counters["feature_report"]))

    def network(self, features: np.ndarray) -> np.ndarray:
        """The raw network on a batch of feature rows (n, n_features) -> (n, 2), m/s."""
        X = np.ascontiguousarray(features, dtype=np.float32).reshape(-1, self.layout.size)
        return self.session.run([OUTPUT_NAME], {INPUT_NAME: X})[0]

    def predict_free_path(self, situation: Situation, ref_ahead: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pass 1: roll the network forward H steps without obstacles.

        ``ref_ahead``: desired poses at steps 0..2H-1 (the window of step j is j..j+H).
        Returns predicted poses (H, 3) after each step and the wheel speeds (H, 2).
        """
        poses, wheels = self._free_path(situation.robot, ref_ahead)
        H = self.horizon
        return np.array(poses).reshape(H, 3), np.array(wheels).reshape(H, 2)

    def _free_path(self, r, ref_ahead: np.ndarray) -> tuple[list, list]:
        """:meth:`predict_free_path` from robot state ``r``, as flat lists of plain floats:
        the poses ``[x1, y1, th1, x2, ...]`` and the wheel speeds ``[vr1, vl1, vr2, ...]``."""
        H, T, W = self.horizon, self.sample_time_s, self.robot.wheel_base_m
        x, y, th, vr, vl = r.x_m, r.y_m, r.heading_rad, r.v_right_mps, r.v_left_mps
        # the features of each step's obstacle-free situation (RobotState(x, y, th, vr, vl),
        # ref_ahead[j:j + H + 1]) packed straight into the bound input row; plain floats
        # throughout (numpy's per-call cost was most of the decision time, measured)
        values = RolloutFeatures(self.layout, ref_ahead[:2 * H], T).values
        write, y1, run, report = self._write, self._y1, self._run, self._counters["feature_report"]
        poses, wheels = [], []
        for j in range(H):
            write(*values(j, x, y, th, vr, vl, report))
            run()
            vr, vl = y1.tolist()
            x, y, th = robot_step_float(x, y, th, vr, vl, T, W)
            poses += (x, y, th)
            wheels += (vr, vl)
        return poses, wheels

    def closest_clearance(self, situation: Situation, poses: np.ndarray) -> float:
        """Smallest clearance of the predicted robot poses (H, 3) to the obstacles' predicted
        positions at the same steps (moving) and to the static obstacles, m."""
        return self._clearance(situation, np.asarray(poses, dtype=float).ravel().tolist())

    def _clearance(self, situation: Situation, poses: list) -> float:
        """:meth:`closest_clearance` of the flat pose list ``[x1, y1, th1, x2, ...]``."""
        return self._clearance_of(situation.tracks, situation.statics, poses)

    def _clearance_of(self, tracks, statics, poses: list) -> float:
        best = math.inf
        rr, hypot = self.robot.radius_m, math.hypot
        xs, ys = poses[0::3], poses[1::3]
        for tr in tracks:
            m = tr.means_m.ravel().tolist()
            d = min(map(hypot, map(sub, xs, m[0::2]), map(sub, ys, m[1::2])))
            best = min(best, d - rr - tr.radius_m)
        for st in statics:
            sx, sy = st.position_m
            d = min(map(hypot, map(sub, xs, repeat(sx)), map(sub, ys, repeat(sy))))
            best = min(best, d - rr - st.radius_m)
        return best

    # --- the step --------------------------------------------------------------------
    def decide(self, obs: Observation) -> ControlDecision:
        """The decision on ``obs``. Its ``info`` says where the time went:
        ``estimation_time_s`` (the filters' updates, the desired poses, and a crowd's
        forecasts, which the crowd network's features read) and ``network_time_s`` (the
        features and the network's calls)."""
        clock = time.perf_counter
        t0 = clock()
        obs, tracks, ref_rows = self.tracker.track_within(obs, self.robot.max_wheel_speed_mps, self._counters)
        # what the decision hands a check layer: the tracks, forecast as the preset's planner
        # forecasts them (made when the check first reads them)
        handed = straight_estimates(tracks) if self._straight_check else tracks
        counters = self._counters
        counters["decisions"] += 1
        self._last = self._last_slots = None  # what rollout() needs, for a one-command decision
        crowd, walls = self._crowd, self._walls
        wall_rows = map_rows(obs.walls) if obs.walls else None  # the map's rows, made once per map
        x, y = obs.robot.x_m, obs.robot.y_m
        side = (walls, wall_rows) if walls is not None and wall_rows is not None and walls.near(x, y, wall_rows) else \
            (crowd, None) if crowd is not None and crowd.needed(x, y, tracks, obs.static) else None
        statics = obs.static
        if side is not None:  # the walls network near a wall, else the crowd network where the main one cannot hold it
            net, rows = side
            if net is walls and statics and self.statics_as_walls:  # the discs in its scan, as a range sensor sees them
                rows, statics = scan_rows(rows, statics, self._disc_rows(statics))
            batch = getattr(tracks[0], "batch_", None) if tracks else None
            if batch is not None:
                batch.arrays  # the forecasts made together, as the features and a check read them
            t1 = clock()
            counters[net.role + "_network"] += 1
            lay, slots = net.layout, None
            if CrowdSlots.overflows(lay, tracks, statics):
                # more than its slots hold: the nearest sorted out in one compiled call (the same values)
                slots = self._last_slots = CrowdSlots.make(lay, tracks, statics, rows)
            if slots is not None:
                r = obs.robot
                values = slots.values(r.x_m, r.y_m, r.heading_rad, r.v_right_mps, r.v_left_mps, ref_rows,
                                      self.sample_time_s, counters["feature_report"])
            else:
                values = feature_values_from(lay, obs.robot, ref_rows, self.sample_time_s, tracks, statics,
                                             counters["feature_report"], rows)
            if net.steps > 1:
                dec = _plan_decision(net.plan(values), f"one pass: {net.role} network plan", handed)
            else:
                vr, vl = net.answer(values)
                self._last = (net.layout, net.answer, obs, tracks, statics, vr, vl, self.tracker.clock.s_m, rows)
                dec = (self._walls_decision if net is walls else self._crowd_decision)(vr, vl, handed)
        elif not self.two_pass:
            t1 = clock()
            own_rows = wall_rows if self.layout.wall_sectors else None
            values = feature_values_from(self.layout, obs.robot, ref_rows, self.sample_time_s, tracks, obs.static,
                                         counters["feature_report"], own_rows)
            if self.steps > 1:
                dec = _plan_decision(self._net_plan(values), "one pass: plan", handed)
            else:
                vr, vl = self._net_values(values)
                self._last = (self.layout, self._net_answer, obs, tracks, obs.static, vr, vl, self.tracker.clock.s_m,
                              own_rows)
                dec = self._one_pass_decision(vr, vl, handed)
        else:
            t1 = clock()
            dec = self._two_passes(obs, tracks, ref_rows, handed)
        held = goal_hold(dec, obs, self.tracker.clock.s_m, self.horizon)
        if held is not None:
            counters["goal_holds"] += 1
            dec = held
        info = dec.info
        info["estimation_time_s"], info["network_time_s"] = t1 - t0, clock() - t1
        return dec

    def rollout(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The last decision's network rolled forward over the horizon against the forecasts
        it was made with (:func:`~nn_export.runtime.rollout.roll_out`): its plan ``(H, 2)``,
        whose first step is the decision's command, and the poses ``(H, 3)``; None when the
        last decision was not one network's single command (two passes, a plan network).
        What a check layer judges as the network's own plan (``CheckSettings(rollouts=True)``)."""
        last = self._last
        if last is None:
            return None
        layout, answer, obs, tracks, statics, vr, vl, s_m, wall_rows = last
        rows = reference_rows(obs.reference, s_m, self.sample_time_s, 2 * self.horizon - 1)
        # a crowd's features at each step from the compiled slots, where they answer (the same
        # values): the decision's own where it made them (a crowd larger than the slots), else made
        # now (the decision's features stayed in plain floats: one call, where making the arrays
        # costs more than it saves)
        slots = self._last_slots
        if slots is None or slots.layout is not layout:
            slots = CrowdSlots.make(layout, tracks, statics, wall_rows)
        return roll_out(layout, answer, obs.robot, (vr, vl), tracks, statics, rows, self.sample_time_s, self.robot,
                        wall_rows, slots)

    def _disc_rows(self, statics) -> np.ndarray:
        """The static discs as wall segments (:func:`static_wall_rows`), made again only when
        the set of discs changes."""
        if statics is not self._static_key:
            self._static_key, self._static_rows = statics, static_wall_rows(statics)
        return self._static_rows

    def _two_passes(self, obs: Observation, tracks: tuple, ref_rows: list, handed: tuple) -> ControlDecision:
        """The paper's scheme (module docstring), from the sample's track estimates and the
        desired poses at steps 0..2H-1 (``handed``: the estimates the decision hands a check)."""
        H, r = self.horizon, obs.robot
        pose_list, wheel_list = self._free_path(r, ref_rows)
        statics = obs.static
        clearance = self._clearance_of(tracks, statics, pose_list)
        poses, wheels = np.array(pose_list).reshape(H, 3), np.array(wheel_list).reshape(H, 2)
        if clearance >= self.safety_distance_m:
            return ControlDecision(wheel_list[0], wheel_list[1], False, "pass 1: path clear",
                                   wheels, poses, info={"predicted_clearance_m": clearance}, forecasts=handed)
        self._counters["second_pass"] += 1
        # the features of the situation with the predicted poses as its reference, from its pieces
        desired = [(r.x_m, r.y_m, r.heading_rad), *zip(pose_list[0::3], pose_list[1::3], pose_list[2::3])]
        vr, vl = self._net_values(feature_values_from(self.layout, r, desired, self.sample_time_s, tracks, statics,
                                                      self._counters["feature_report"]))
        return ControlDecision(vr, vl, False, "pass 2: avoiding", wheels, poses,
                               info={"predicted_clearance_m": clearance}, forecasts=handed)
