"""casadi_gpc.buffered: a CasADi function called through its buffer gives what the ordinary
call gives, bit for bit, and refuses what it cannot bind."""
import numpy as np
import pytest

ca = pytest.importorskip("casadi")

from casadi_gpc.buffered import BufferedFunction  # noqa: E402


def test_inputs_outputs_and_shapes_match_the_ordinary_call():
    x, m = ca.SX.sym("x", 3), ca.SX.sym("m", 2, 2)
    fn = ca.Function("f", [x, m], [ca.sin(x) * ca.trace(m), ca.mtimes(m, m.T) + x[0]], ["x", "m"], ["a", "b"])
    bf = BufferedFunction(fn)
    rng = np.random.default_rng(0)
    for _ in range(3):
        xv, mv = rng.normal(size=3), rng.normal(size=(2, 2))
        assert bf(xv, mv) == 0
        a, b = fn(xv, mv)
        np.testing.assert_array_equal(bf.output(0), np.asarray(a))
        np.testing.assert_array_equal(bf.output(1), np.asarray(b))  # (2, 2), CasADi's column order undone
    # None keeps an input as it is; the outputs are overwritten by the next call, output() copies
    kept = bf.output(1)
    bf(np.zeros(3), None)
    np.testing.assert_array_equal(bf.output(1), np.asarray(fn(np.zeros(3), mv)[1]))
    assert not np.array_equal(kept, bf.output(1))


def test_shared_inputs_read_the_same_array():
    x = ca.SX.sym("x", 2)
    f, g = ca.Function("f", [x], [ca.sumsqr(x)]), ca.Function("g", [x], [ca.norm_inf(x)])
    bf = BufferedFunction(f)
    bg = BufferedFunction(g, share={0: bf.inputs[0]})
    bf.inputs[0][:] = [3.0, -4.0]
    bg()
    bf()
    assert bf.outputs[0][0] == 25.0 and bg.outputs[0][0] == 4.0


def test_refuses_sparse_inputs_and_wrong_shared_arrays():
    x = ca.SX.sym("x", ca.Sparsity.diag(2))
    with pytest.raises(ValueError, match="not dense"):
        BufferedFunction(ca.Function("f", [x], [ca.sum1(ca.sum2(x))]))
    y = ca.SX.sym("y", 3)
    with pytest.raises(ValueError, match="contiguous float vector of 3"):
        BufferedFunction(ca.Function("g", [y], [y]), share={0: np.zeros(2)})


def test_an_nlp_solved_through_the_buffer_equals_the_ordinary_solve():
    """The planner's SQP backend through its buffer against the same CasADi solver called the
    ordinary way (DM in, DM out), on a recorded crossing problem: the same numbers."""
    from casadi_gpc.config import preset
    from casadi_gpc.problem.cost import build_problem
    from casadi_gpc.solvers import make_backend

    cfg = preset("paper")
    pr = build_problem(cfg)
    be = make_backend("sqpmethod-daqp", pr, compiled=False)
    p = pr.layout.pack(np.array([0.0, 0.0, 0.0, 0.2, 0.2]),
                       np.array([[0.3 * (k + 1), 0.0, 0.0] for k in range(cfg.horizon)]))
    u0 = np.full(pr.n_u, 0.01)
    r = be.solve(p, u0)
    assert r.success
    scale = be.solver.inputs[1][-1]
    out = be.solver.fn.call([ca.DM(u0), ca.DM(np.append(p, scale)), *(ca.DM(b) for b in (pr.lbx, pr.ubx, pr.lbg, pr.ubg)),
                             ca.DM(), ca.DM()])
    np.testing.assert_array_equal(r.u, np.asarray(out[0]).ravel())
    assert r.cost == float(out[1]) / scale
