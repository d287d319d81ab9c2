"""Known-answer tests of the exact-arc differential-drive model (casadi_gpc.robot).

The reference is a fine numerical integration of the wheel-speed ODE
``x' = V cos(th), y' = V sin(th), th' = A`` with ``V = (Vr + Vl)/2``, ``A = (Vr - Vl)/W``.
"""
from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from casadi_gpc.robot import RobotParams, RobotState, brake_wheels, robot_step, sinc, wheel_to_unicycle

W = RobotParams().wheel_base_m


def integrate(x, y, th, vr, vl, dt, wheel_base_m=W):
    """Pose after ``dt`` s at constant wheel speeds, by DOP853 at tolerance 1e-13."""
    v, a = 0.5 * (vr + vl), (vr - vl) / wheel_base_m

    def rhs(_t, s):
        return [v * np.cos(s[2]), v * np.sin(s[2]), a]

    sol = solve_ivp(rhs, (0.0, dt), [x, y, th], method="DOP853", rtol=1e-13, atol=1e-13)
    assert sol.success
    return sol.y[:, -1]


def _cases():
    rng = np.random.default_rng(1)
    cases = [
        # (x, y, th, vr, vl, dt)
        (0.0, 0.0, 0.0, 0.5, 0.5, 1.5),            # Vr = Vl: a straight line
        (1.0, -2.0, 2.3, -0.8, -0.8, 1.0),         # straight backwards
        (0.3, 0.4, -1.0, 0.6, -0.6, 1.5),          # Vr = -Vl: turning on the spot
        (0.0, 0.0, 3.0, -0.8, 0.8, 0.5),
        (0.0, 0.0, 0.7, 0.8, 0.8 - 1e-9, 1.5),     # almost straight, inside the Taylor branch
        (0.0, 0.0, 0.7, 0.8, 0.8 - 4e-3, 0.5),     # just beyond the Taylor switch (|u| = 2e-3)
        (0.0, 0.0, 0.7, 0.8, 0.8 - 2e-3, 0.5),     # at the switch (|u| = 1e-3)
        (5.0, 5.0, -3.1, 0.8, 0.0, 1.5),           # one wheel stopped
    ]
    for _ in range(20):
        vr, vl = rng.uniform(-0.8, 0.8, 2)
        cases.append((*rng.uniform(-5, 5, 2), rng.uniform(-np.pi, np.pi), vr, vl, rng.choice([0.5, 1.0, 1.5])))
    return cases


@pytest.mark.parametrize("case", _cases())
def test_step_matches_fine_integration(case):
    x, y, th, vr, vl, dt = case
    got = np.array(robot_step(np, x, y, th, vr, vl, dt, W), dtype=float)
    want = integrate(x, y, th, vr, vl, dt)
    assert np.hypot(got[0] - want[0], got[1] - want[1]) < 1e-9
    assert abs(got[2] - want[2]) < 1e-9


def test_known_answers():
    # Vr = -Vl: the position does not move, the heading turns by (Vr - Vl) T / W exactly
    x, y, th = robot_step(np, 1.0, 2.0, 0.5, 0.4, -0.4, 1.5, W)
    assert (x, y) == (1.0, 2.0)
    assert th == pytest.approx(0.5 + 0.8 * 1.5 / W, abs=1e-15)
    # Vr = Vl: a straight line of length V T
    x, y, th = robot_step(np, 0.0, 0.0, np.pi / 6, 0.6, 0.6, 1.5, W)
    assert x == pytest.approx(0.9 * np.cos(np.pi / 6), abs=1e-15)
    assert y == pytest.approx(0.9 * np.sin(np.pi / 6), abs=1e-15)
    assert th == np.pi / 6
    # a quarter circle of radius R = W/2 (Vl = 0), starting at the origin heading along x
    vr = 0.8
    dt = (np.pi / 2) / (vr / W)
    x, y, th = robot_step(np, 0.0, 0.0, 0.0, vr, 0.0, dt, W)
    assert (x, y, th) == pytest.approx((W / 2, W / 2, np.pi / 2), abs=1e-14)


def test_many_steps_match_piecewise_integration():
    rng = np.random.default_rng(7)
    s = np.array([0.0, 0.0, 0.0])
    ref = s.copy()
    for _ in range(40):
        vr, vl = rng.uniform(-0.8, 0.8, 2)
        if rng.random() < 0.3:
            vl = vr
        s = np.array(robot_step(np, *s, vr, vl, 0.5, W), dtype=float)
        ref = integrate(*ref, vr, vl, 0.5)
    assert np.hypot(*(s[:2] - ref[:2])) < 1e-9
    assert abs(s[2] - ref[2]) < 1e-9


def test_vectorised_numpy_equals_scalar():
    rng = np.random.default_rng(2)
    args = rng.uniform(-1, 1, (6, 50))
    args[3, :10] = args[4, :10]  # some straight
    out = np.array(robot_step(np, *args[:5], np.abs(args[5]) + 0.1, W))
    for k in range(50):
        one = robot_step(np, *args[:5, k], abs(args[5, k]) + 0.1, W)
        np.testing.assert_array_equal(out[:, k], np.array(one, dtype=float))


def _casadi_step():
    s = ca.SX.sym("s", 6)  # x, y, th, vr, vl, dt
    out = ca.vertcat(*robot_step(ca, s[0], s[1], s[2], s[3], s[4], s[5], W))
    v = s[3:5]
    return (ca.Function("f", [s], [out]), ca.Function("J", [s], [ca.jacobian(out, v)]),
            ca.Function("Hx", [s], [ca.hessian(out[0], v)[0]]))


def test_casadi_form_equals_numpy_form():
    f, _, _ = _casadi_step()
    for x, y, th, vr, vl, dt in _cases():
        got = np.asarray(f([x, y, th, vr, vl, dt])).ravel()
        want = np.array(robot_step(np, x, y, th, vr, vl, dt, W), dtype=float)
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-14)


def _jacobian_at_straight(th, v, dt):
    """d(x, y, th)/d(vr, vl) at Vr = Vl = v, derived by hand from the arc."""
    c, s = np.cos(th), np.sin(th)
    k = v * dt ** 2 / (2 * W)
    return np.array([
        [dt / 2 * c - k * s, dt / 2 * c + k * s],
        [dt / 2 * s + k * c, dt / 2 * s - k * c],
        [dt / W, -dt / W],
    ])


@pytest.mark.parametrize("dt", [0.5, 1.5])
def test_smooth_through_equal_wheel_speeds(dt):
    """The jacobian is finite at Vr = Vl, equals the hand-derived limit there, and moves
    continuously (Lipschitz) as Vr - Vl crosses 0 and the Taylor switch of the sinc."""
    _, J, Hx = _casadi_step()
    x, y, th, v = 0.3, -0.2, 0.9, 0.5
    switch = 2e-3 * W / dt  # Vr - Vl where |A T / 2| = 1e-3, the sinc's branch switch
    j0 = np.asarray(J([x, y, th, v, v, dt]))
    np.testing.assert_allclose(j0, _jacobian_at_straight(th, v, dt), rtol=0, atol=1e-14)
    diffs = [s * m for s in (-1, 1) for m in (1e-12, 1e-8, 1e-5, switch * (1 - 1e-9), switch * (1 + 1e-9),
                                              3 * switch, 0.05)]
    for d in diffs:
        jd = np.asarray(J([x, y, th, v + d / 2, v - d / 2, dt]))
        assert np.all(np.isfinite(jd))
        assert np.max(np.abs(jd - j0)) <= 10.0 * abs(d) + 1e-14, d
        assert np.all(np.isfinite(np.asarray(Hx([x, y, th, v + d / 2, v - d / 2, dt]))))
    # no jump at the Taylor switch, to rounding
    lo = np.asarray(J([x, y, th, v + switch * (1 - 1e-12) / 2, v - switch * (1 - 1e-12) / 2, dt]))
    hi = np.asarray(J([x, y, th, v + switch * (1 + 1e-12) / 2, v - switch * (1 + 1e-12) / 2, dt]))
    assert np.max(np.abs(hi - lo)) < 1e-12
    h0 = np.asarray(Hx([x, y, th, v, v, dt]))
    assert np.all(np.isfinite(h0))


def test_jacobian_matches_finite_differences():
    _, J, _ = _casadi_step()
    rng = np.random.default_rng(3)
    for k in range(20):
        x, y, th = rng.uniform(-2, 2, 3)
        vr, vl = rng.uniform(-0.8, 0.8, 2)
        if k % 3 == 0:
            vl = vr
        dt = 0.5
        h = 1e-6
        fd = np.empty((3, 2))
        for i in range(2):
            e = np.zeros(2)
            e[i] = h
            plus = np.array(robot_step(np, x, y, th, vr + e[0], vl + e[1], dt, W), dtype=float)
            minus = np.array(robot_step(np, x, y, th, vr - e[0], vl - e[1], dt, W), dtype=float)
            fd[:, i] = (plus - minus) / (2 * h)
        np.testing.assert_allclose(np.asarray(J([x, y, th, vr, vl, dt])), fd, rtol=0, atol=1e-8)


def test_sinc_agrees_with_numpy_across_the_switch():
    u = np.concatenate([np.linspace(-0.01, 0.01, 2001), [0.0, 1e-3, -1e-3, 1e-3 * (1 + 1e-12), 1e-300, 2.5]])
    np.testing.assert_allclose(sinc(np, u), np.sinc(u / np.pi), rtol=2e-16, atol=0)
    sym = ca.SX.sym("u")
    f = ca.Function("s", [sym], [sinc(ca, sym)])
    np.testing.assert_allclose([float(f(v)) for v in u], np.sinc(u / np.pi), rtol=2e-16, atol=0)


def test_wheel_helpers():
    assert wheel_to_unicycle(0.6, 0.2, 0.5) == pytest.approx((0.4, 0.8))
    assert brake_wheels(0.5, -0.3, 0.4) == pytest.approx((0.1, 0.0))
    assert brake_wheels(-0.5, 0.05, 0.4) == pytest.approx((-0.1, 0.0))
    assert RobotParams().max_step_change_mps(0.5) == pytest.approx(0.4)
    st = RobotState(1.0, 2.0, 0.3, 0.4, 0.5)
    np.testing.assert_array_equal(st.as_array(), [1.0, 2.0, 0.3, 0.4, 0.5])


@pytest.mark.parametrize("field, value", [("radius_m", -1.0), ("wheel_base_m", float("nan")),
                                          ("max_wheel_speed_mps", 0.0), ("max_wheel_accel_mps2", float("inf")),
                                          ("radius_m", "0.3"), ("wheel_base_m", True)])
def test_robot_params_that_are_no_robot_are_refused_naming_the_field(field, value):
    """A radius of -1 or a NaN wheel base was taken (OnnxPolicy then said the model was "trained for
    another robot"); each field must be a positive number, as a scenario file's."""
    from casadi_gpc.robot import RobotParams
    with pytest.raises(ValueError, match=rf"^RobotParams\.{field} must be a positive number, got "):
        RobotParams(**{field: value})
    assert RobotParams(**{field: 0.3}).to_dict()[field] == 0.3
