"""Property-based tests (hypothesis) over the public pieces: the robot model, the obstacle
EKF, the features, the safety filter, the GPC and both policies. Random valid inputs give
finite answers within the limits; invalid inputs raise the documented error.

Example counts are kept small (the GPC solves an NLP per example) so the module runs in
about half a minute; ``HYPOTHESIS_PROFILE=thorough`` runs ten times more examples.
"""
from __future__ import annotations

import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from casadi_gpc.config import preset
from casadi_gpc.estimation.ekf import ObstacleEKF
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState, brake_wheels, robot_step, wheel_to_unicycle
from casadi_gpc.types import ObstacleForecast, ObstacleMeasurement, Observation, StaticObstacle
from nn_export.runtime.features import compute_features
from nn_export.runtime.layouts import layout_for
from nn_export.runtime.situation import Situation, TrackEstimate, reference_poses
from casadi_gpc.safety import SafetyFilter, Shield

ROBOT = RobotParams()
VMAX = ROBOT.max_wheel_speed_mps
SCALE = 10 if os.environ.get("HYPOTHESIS_PROFILE") == "thorough" else 1


def examples(n):
    return settings(max_examples=n * SCALE, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


finite = st.floats(allow_nan=False, allow_infinity=False)
coord = st.floats(-20.0, 20.0)
angle = st.floats(-4 * math.pi, 4 * math.pi)
wheel = st.floats(-VMAX, VMAX)
dt = st.floats(0.0, 3.0)


# --- the robot model ---------------------------------------------------------------------------
@examples(300)
@given(coord, coord, angle, wheel, wheel, dt)
def test_robot_step_is_finite_exact_in_heading_and_no_longer_than_the_arc(x, y, h, vr, vl, t):
    x1, y1, h1 = robot_step(np, x, y, h, vr, vl, t, ROBOT.wheel_base_m)
    assert np.isfinite([x1, y1, h1]).all()
    v, a = wheel_to_unicycle(vr, vl, ROBOT.wheel_base_m)
    assert h1 == pytest.approx(h + a * t, abs=1e-12)
    # a chord is never longer than its arc, and equals it on a straight line
    chord = math.hypot(x1 - x, y1 - y)
    assert chord <= abs(v) * t + 1e-12
    if vr == vl:
        assert chord == pytest.approx(abs(v) * t, abs=1e-12)


@examples(200)
@given(wheel, wheel, st.floats(0.0, 2.0))
def test_brake_wheels_moves_each_wheel_towards_zero_within_the_limit(vr, vl, dv):
    br, bl = brake_wheels(vr, vl, dv)
    for before, after in ((vr, br), (vl, bl)):
        assert abs(after) <= abs(before)
        assert abs(after - before) <= dv + 1e-15
        assert after == 0.0 or np.sign(after) == np.sign(before)


# --- the obstacle EKF --------------------------------------------------------------------------
measurement = st.one_of(
    st.none(),
    st.tuples(st.floats(-50, 50), st.floats(-50, 50)),
    st.tuples(st.sampled_from([math.nan, math.inf, -math.inf]), finite),
)


@examples(150)
@given(st.lists(measurement, min_size=1, max_size=30), st.sampled_from([0.5, 1.5]), st.integers(1, 12))
def test_ekf_stays_finite_and_its_covariance_positive_whatever_it_is_fed(zs, T, H):
    ekf = ObstacleEKF(T)
    for z in zs:
        assert ekf.step(z) in ("start", "update", "missed", "outlier", "manoeuvre")  # ObstacleEKF.step's answers
    if ekf.state_ is None:
        with pytest.raises(RuntimeError):
            ekf.predict(H)
        return
    assert np.isfinite(ekf.state_).all() and np.isfinite(ekf.cov_).all()
    np.testing.assert_allclose(ekf.cov_, ekf.cov_.T, atol=1e-9 * max(1.0, np.abs(ekf.cov_).max()))
    assert np.linalg.eigvalsh(ekf.cov_).min() >= -1e-9 * max(1.0, np.abs(ekf.cov_).max())
    means, covs = ekf.predict(H)
    assert means.shape == (H, 2) and covs.shape == (H, 2, 2)
    assert np.isfinite(means).all() and np.isfinite(covs).all()
    assert (np.trace(covs, axis1=1, axis2=2) > 0).all()
    assert ekf.missed_ + ekf.outliers_ <= len(zs)


@examples(30)
@given(st.lists(st.floats(-5, 5), min_size=3, max_size=3) | st.just([1.0]))
def test_ekf_refuses_a_measurement_that_is_not_a_position(z):
    with pytest.raises(ValueError, match="position"):
        ObstacleEKF(0.5).step(z)


# --- the features ------------------------------------------------------------------------------
@st.composite
def situations(draw, preset_name):
    cfg = preset(preset_name)
    H, T = cfg.horizon, cfg.sample_time_s
    segs = [Segment.line(draw(st.floats(0.5, 10.0)))]
    if draw(st.booleans()):
        segs.append(Segment.arc(draw(st.floats(0.5, 8.0)), draw(st.floats(-3.0, 3.0).filter(lambda a: abs(a) > 1e-3))))
    path = ReferencePath((draw(coord), draw(coord)), draw(angle), tuple(segs), draw(st.floats(0.05, 0.7)))
    ref = reference_poses(path, draw(st.floats(0.0, path.length_m)), T, H)
    robot = RobotState(draw(coord), draw(coord), draw(angle), draw(wheel), draw(wheel))
    tracks = []
    for i in range(draw(st.integers(0, 4))):
        s = np.array([draw(coord), draw(coord), draw(st.floats(0.0, 1.5)), draw(angle), draw(st.floats(-0.5, 0.5))])
        L = np.array([[draw(st.floats(1e-3, 1.0)), 0.0], [draw(st.floats(-0.5, 0.5)), draw(st.floats(1e-3, 1.0))]])
        cov2 = L @ L.T
        cov = np.eye(5) * 0.01
        cov[:2, :2] = cov2
        k = np.arange(1, H + 1)[:, None]
        means = s[:2] + k * T * s[2] * np.array([math.cos(s[3]), math.sin(s[3])])
        covs = np.array([cov2 * (1 + j) for j in range(H)])
        tracks.append(TrackEstimate(i, draw(st.floats(0.1, 0.6)), s, cov, means, covs))
    statics = tuple(StaticObstacle((draw(coord), draw(coord)), draw(st.floats(0.1, 0.6)))
                    for _ in range(draw(st.integers(0, 4))))
    return Situation(robot, ref, T, path.speed_mps, tuple(tracks), statics)


@examples(60)
@given(st.data(), st.sampled_from(["paper", "improved"]), st.sampled_from(["paper", "multi"]))
def test_features_are_finite_and_of_the_layout_size(data, preset_name, layout_name):
    situation = data.draw(situations(preset_name))
    layout = layout_for(layout_name, preset(preset_name).horizon)
    report = {}
    f = compute_features(layout, situation, report=report)
    assert f.shape == (layout.size,) and np.isfinite(f).all()
    assert all(isinstance(v, int) and v >= 0 for v in report.values())


@examples(20)
@given(st.data(), st.integers(1, 20))
def test_features_refuse_a_situation_of_another_horizon(data, horizon):
    situation = data.draw(situations("paper"))
    if horizon == situation.horizon:
        horizon += 1
    with pytest.raises(ValueError, match="horizon"):
        compute_features(layout_for("paper", horizon), situation)


@examples(20)
@given(st.text(min_size=1, max_size=8).filter(lambda s: s not in ("paper", "multi")), st.integers(-3, 0))
def test_layout_refuses_unknown_names_and_horizons(name, horizon):
    with pytest.raises(ValueError, match="layout"):
        layout_for(name, 6)
    with pytest.raises(ValueError, match="horizon"):
        layout_for("paper", horizon)


# --- observations ------------------------------------------------------------------------------
@examples(30)
@given(st.sampled_from(["t", "x", "y", "h", "vr", "vl"]), st.sampled_from([math.nan, math.inf, -math.inf]))
def test_observation_refuses_a_non_finite_time_or_robot_state(which, bad):
    vals = {"t": 1.0, "x": 0.0, "y": 0.0, "h": 0.0, "vr": 0.1, "vl": 0.1, which: bad}
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(5.0),), 0.4)
    with pytest.raises(ValueError, match="non-finite"):
        Observation(vals["t"], RobotState(vals["x"], vals["y"], vals["h"], vals["vr"], vals["vl"]), ref)


@examples(30)
@given(st.sampled_from(["moving radius", "static radius", "static x", "static y"]),
       st.sampled_from([math.nan, math.inf, -math.inf, -0.3]))
def test_observation_refuses_an_obstacle_of_no_known_size_or_place(which, bad):
    """A NaN radius or a NaN static obstacle had the planner fail every solve and brake for
    good; a negative radius passed silently. A position measurement that is not finite stays
    a sensor fault (skipped and counted by the filters), not an error."""
    from casadi_gpc.types import ObstacleMeasurement, StaticObstacle
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(5.0),), 0.4)
    robot = RobotState(0.0, 0.0, 0.0, 0.1, 0.1)
    mover = ObstacleMeasurement(1, (3.0, 0.0), bad if which == "moving radius" else 0.3)
    static = StaticObstacle((bad if which == "static x" else 2.0, bad if which == "static y" else 1.0),
                            bad if which == "static radius" else 0.3)
    if which == "static x" and bad == -0.3 or which == "static y" and bad == -0.3:
        Observation(1.0, robot, ref, (mover,), (static,))  # a negative coordinate is a place like any
        return
    with pytest.raises(ValueError, match="obstacle"):
        Observation(1.0, robot, ref, (mover,), (static,))
    Observation(1.0, robot, ref, (ObstacleMeasurement(1, (math.nan, 0.0), 0.3),))  # a sensor fault: no error


def test_observation_refuses_two_moving_obstacles_under_one_id():
    """The filters are kept by id: two people under one id were fused into one phantom, its
    filter stepped twice a sample (a 3 m/s obstacle: the check layer reversed at full speed
    from two people standing 2 and 3 m away), neither forecast where it was."""
    from casadi_gpc.types import ObstacleMeasurement
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(5.0),), 0.4)
    robot = RobotState(0.0, 0.0, 0.0)
    movers = (ObstacleMeasurement(0, (2.0, 0.0), 0.3), ObstacleMeasurement(1, (2.0, 0.0), 0.3),
              ObstacleMeasurement(0, (3.0, 1.0), 0.3))
    with pytest.raises(ValueError) as exc:
        Observation(0.5, robot, ref, movers)
    assert str(exc.value) == ("observation at t=0.5 s: moving obstacle id 0 is listed twice (an id is one obstacle's "
                              "track: two people under one id were one phantom, stepped twice a sample)")
    Observation(0.5, robot, ref, movers[:2])  # distinct ids, one place: two obstacles


def test_wheel_speeds_reported_beyond_the_limits_are_held_to_them_and_counted():
    """A glitching encoder (5 m/s on a 0.8 m/s robot): the planner's every solve failed from a
    state its limits forbid and its brake commanded 4.6 m/s. Now the planner and the check layer
    start from the limits, and count it; the command is within them."""
    from casadi_gpc.config import preset
    from gpcnav.controllers import ControllerSpec, make
    from casadi_gpc.planner.gpc import GPCController
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(12.0),), 0.4)
    glitch = Observation(0.0, RobotState(0.0, 0.0, 0.0, 5.0, -5.0), ref)
    held = glitch.with_wheels_within(VMAX)
    assert (held.robot.v_right_mps, held.robot.v_left_mps) == (VMAX, -VMAX)
    assert Observation(0.0, RobotState(0.0, 0.0, 0.0, VMAX, -VMAX), ref).with_wheels_within(VMAX) is None
    bare = GPCController(preset("improved"), ROBOT)
    bare.reset()
    d = bare.decide(glitch)
    assert not d.fallback and abs(d.v_right_mps) <= VMAX and abs(d.v_left_mps) <= VMAX
    assert bare.counters["wheel_state_held"] == 1
    for name in ("gpc", "nn"):
        ctl = make(ControllerSpec(name), preset("improved"), ROBOT)
        ctl.reset()
        d = ctl.decide(glitch)
        assert abs(d.v_right_mps) <= VMAX and abs(d.v_left_mps) <= VMAX, name
        assert ctl.counters["shield_wheel_state_held"] == 1, name


# --- the safety filter -------------------------------------------------------------------------
def assert_within_limits(cmd, v0, T):
    dv = ROBOT.max_step_change_mps(T)
    cmd = np.asarray(cmd, float)
    assert np.isfinite(cmd).all()
    assert np.all(np.abs(cmd) <= VMAX + 1e-9)
    assert np.all(np.abs(cmd - np.asarray(v0)) <= dv + 1e-9)


@examples(80)
@given(st.data(), st.sampled_from([(0.5, 12), (1.5, 6)]))
def test_safety_filter_answers_finite_commands_within_the_limits(data, TH):
    T, H = TH
    f = SafetyFilter(ROBOT, T, H)
    state = [data.draw(st.floats(-5, 5)), data.draw(st.floats(-5, 5)), data.draw(angle), data.draw(wheel),
             data.draw(wheel)]
    cand = data.draw(st.one_of(
        st.lists(st.floats(-2.0, 2.0), min_size=2, max_size=2),
        st.lists(st.lists(st.floats(-2.0, 2.0), min_size=2, max_size=2), min_size=H, max_size=H),
        st.just([math.nan, 0.0])))
    fcs = []
    for i in range(data.draw(st.integers(0, 3))):
        p0, v = np.array([data.draw(st.floats(-5, 5)), data.draw(st.floats(-5, 5))]), data.draw(
            st.lists(st.floats(-0.6, 0.6), min_size=2, max_size=2))
        means = p0 + T * np.arange(1, H + 1)[:, None] * np.asarray(v)
        covs = np.array([np.eye(2) * data.draw(st.floats(1e-6, 0.5)) * (j + 1) for j in range(H)])
        fcs.append(ObstacleForecast(i, data.draw(st.floats(0.1, 0.5)), means, covs))
    statics = tuple(StaticObstacle((data.draw(st.floats(-5, 5)), data.draw(st.floats(-5, 5))), 0.3)
                    for _ in range(data.draw(st.integers(0, 2))))
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(5.0),), 0.4)
    obs = Observation(0.0, RobotState(*state), ref, (), statics)
    v = f.filter(obs, np.asarray(cand, float), fcs)
    assert_within_limits([v.v_right_mps, v.v_left_mps], state[3:], T)
    assert f.counters["checks"] == 1
    # counted when the command was changed: not a candidate kept because nothing did better
    assert f.counters["interventions"] == int(v.intervened and v.source != "candidate")
    assert v.intervened == (not v.check.safe)


# --- the controllers ---------------------------------------------------------------------------
@st.composite
def observation_streams(draw, steps=3, T=0.5):
    """A few consecutive observations of a robot within the limits, 0-2 moving obstacles
    (sometimes missing, non-finite or far off), 0-2 static ones away from the robot."""
    segs = (Segment.line(draw(st.floats(1.0, 15.0))),)
    ref = ReferencePath((0.0, 0.0), draw(st.floats(-3, 3)), segs, draw(st.floats(0.1, 0.6)))
    x, y, h = draw(st.floats(-2, 2)), draw(st.floats(-2, 2)), draw(st.floats(-3, 3))
    vr, vl = draw(st.floats(-0.8, 0.8)), draw(st.floats(-0.8, 0.8))
    n = draw(st.integers(0, 2))
    starts = [(draw(st.floats(-6, 6)), draw(st.floats(-6, 6)), draw(st.floats(-0.5, 0.5)), draw(st.floats(-0.5, 0.5)))
              for _ in range(n)]
    statics = []
    for _ in range(draw(st.integers(0, 2))):
        sx, sy = draw(st.floats(-6, 6)), draw(st.floats(-6, 6))
        if math.hypot(sx - x, sy - y) > 1.2:
            statics.append(StaticObstacle((sx, sy), 0.3))
    out = []
    for k in range(steps):
        ms = []
        for i, (ox, oy, ovx, ovy) in enumerate(starts):
            kind = draw(st.sampled_from(["ok", "ok", "ok", "none", "nan", "far"]))
            p = (ox + ovx * k * T, oy + ovy * k * T)
            if kind == "none":
                p = None
            elif kind == "nan":
                p = (math.nan, p[1])
            elif kind == "far":
                p = (p[0] + 5.0, p[1])
            ms.append(ObstacleMeasurement(i, p, 0.3))
        out.append(Observation(k * T, RobotState(x, y, h, vr, vl), ref, tuple(ms), tuple(statics)))
        x, y, h = (float(v) for v in robot_step(np, x, y, h, vr, vl, T, ROBOT.wheel_base_m))
    return out


@pytest.fixture(scope="module")
def gpcs():
    pytest.importorskip("casadi")
    from casadi_gpc.planner.gpc import GPCController
    return {name: GPCController(preset(name)) for name in ("paper", "improved")}


@examples(12)
@given(st.data(), st.sampled_from(["paper", "improved"]))
def test_gpc_answers_finite_commands_within_the_limits(gpcs, data, name):
    ctrl = gpcs[name]
    ctrl.reset()
    T = ctrl.sample_time_s
    for obs in data.draw(observation_streams(steps=2, T=T)):
        d = ctrl.decide(obs)
        # the solver meets its bounds to its tolerance
        dv = ROBOT.max_step_change_mps(T)
        cmd = np.array([d.v_right_mps, d.v_left_mps])
        assert np.isfinite(cmd).all() and np.all(np.abs(cmd) <= VMAX + 1e-6)
        assert np.all(np.abs(cmd - [obs.robot.v_right_mps, obs.robot.v_left_mps]) <= dv + 1e-6)


@pytest.fixture(scope="module")
def policies(tmp_path_factory):
    """OnnxPolicy with each shipped model (if any) and with the synthetic tracker, with and
    without the safety filter."""
    from nn_export import OnnxPolicy
    from nn_export.runtime.policy import shipped_model_path
    from synthetic_models import tracker_model

    out = {}
    d = tmp_path_factory.mktemp("prop_models")
    for name in ("paper", "improved"):
        paths = {"tracker": tracker_model(d / f"tracker_{name}.onnx", name)}
        if shipped_model_path(name).is_file():
            paths["shipped"] = shipped_model_path(name)
        for kind, path in paths.items():
            for safety in (True, False):
                net = OnnxPolicy(path, preset=name)
                out[(name, kind, safety)] = Shield(net) if safety else net
    return out


@examples(40)
@given(st.data())
def test_policies_answer_finite_commands_within_the_speed_limit(policies, data):
    key = data.draw(st.sampled_from(sorted(policies, key=str)))
    pol = policies[key]
    pol.reset()
    T = pol.sample_time_s
    for obs in data.draw(observation_streams(steps=3, T=T)):
        d = pol.decide(obs)
        cmd = np.array([d.v_right_mps, d.v_left_mps])
        # the network's output is clipped to the speed limit inside the graph, in float32
        assert np.isfinite(cmd).all() and np.all(np.abs(cmd) <= VMAX + 1e-6), (key, cmd)
        if d.fallback:  # the safety filter's own answers keep the acceleration limit as well
            assert_within_limits(cmd, [obs.robot.v_right_mps, obs.robot.v_left_mps], T)


def test_walls_of_any_sequence_are_read_as_point_tuples_and_bad_walls_refused():
    """Walls as lists (read from JSON) crashed the check layer as unhashable, numpy arrays the
    truth test; a NaN wall had the planner fail every solve, a one-point wall was dropped."""
    ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(5.0),), 0.4)
    robot = RobotState(0.0, 0.0, 0.0, 0.1, 0.1)
    want = (((-5.0, 1.25), (20.0, 1.25)), ((-5.0, -1.25), (20.0, -1.25)))
    for given in ([[[-5, 1.25], [20, 1.25]], [[-5, -1.25], [20, -1.25]]], np.array(want),
                  tuple(np.array(w) for w in want), want):
        o = Observation(1.0, robot, ref, walls=given)
        assert o.walls == want and all(type(p[0]) is float for w in o.walls for p in w)
    assert Observation(1.0, robot, ref, walls=want).walls is want  # tuples already: as they are
    one_point = (((1.0, 2.0),),)
    nan_point = (((0.0, math.nan), (1.0, 1.0)),)
    three_d = (((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)),)
    flat = ((0.0, 1.0, 2.0, 3.0),)
    for bad, words in ((one_point, "at least two"), (nan_point, "not finite"), (three_d, "polylines of"),
                       (flat, "polylines of")):
        with pytest.raises(ValueError, match=words):
            Observation(1.0, robot, ref, walls=bad)
