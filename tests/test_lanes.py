"""casadi_gpc.planner.lanes: starts solved at once in threads give the very answers solved one after
the other, and the planner's closed loop does not depend on the number of lanes."""
from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("casadi")

from casadi_gpc.config import preset  # noqa: E402
from casadi_gpc.problem.cost import build_problem  # noqa: E402
from casadi_gpc.planner.gpc import GPCController  # noqa: E402
from casadi_gpc.planner.lanes import SolveLanes  # noqa: E402
from casadi_gpc.safety import CheckSettings, Shield  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402
from casadi_gpc.solvers import make_backend  # noqa: E402


def _crossing_problems(cfg, n=12):
    """Parameters and cold starts of a crossing mover at several distances."""
    from casadi_gpc.planner.guesses import initial_guesses
    from casadi_gpc.types import ObstacleForecast

    pr = build_problem(cfg)
    H = cfg.horizon
    x0 = np.array([0.0, 0.0, 0.0, 0.3, 0.3])
    ref = np.array([[0.15 * cfg.sample_time_s * 2 * (k + 1), 0.0, 0.0] for k in range(H)])
    jobs = []
    for i in range(n):
        start = np.array([1.0 + 0.2 * i, -1.5])
        means = start + np.outer(np.arange(1, H + 1) * cfg.sample_time_s, [0.0, 0.3])
        f = ObstacleForecast(1, 0.2, means, np.tile(np.eye(2) * 0.01, (H, 1, 1)))
        p = pr.layout.pack(x0, ref, [f])
        for u0 in initial_guesses(pr, x0, 0.3, ref).values():
            jobs.append((p, u0, None, None))
    return pr, jobs


@pytest.mark.parametrize("solver", ["sqpmethod-daqp", "fatrop", "sqpmethod-daqp+fatrop"])
def test_two_lanes_give_the_answers_of_one(solver):
    cfg = preset("improved")
    pr, jobs = _crossing_problems(cfg)
    one = SolveLanes(make_backend(solver, pr), 1)
    two = SolveLanes(make_backend(solver, pr), 2)
    assert one.count == 1 and two.count == 2
    a, b = one.solve_all(jobs), two.solve_all(jobs)
    assert len(a) == len(b) == len(jobs)
    for (ra, _), (rb, _) in zip(a, b):
        assert ra.success == rb.success and ra.iterations == rb.iterations
        np.testing.assert_array_equal(ra.u, rb.u)
        assert ra.cost == rb.cost or (np.isnan(ra.cost) and np.isnan(rb.cost))


def test_what_cannot_run_in_threads_gets_one_lane():
    pr = build_problem(preset("paper"))
    for name, compiled in (("ipopt-warm", True), ("powell", True), ("sqpmethod-daqp", False)):
        assert SolveLanes(make_backend(name, pr, compiled=compiled), 4).count == 1, name
    with pytest.raises(ValueError, match="whole number >= 1"):
        SolveLanes(make_backend("powell", pr), 0)


def test_a_start_is_not_begun_once_stop_says_so():
    cfg = preset("paper")
    pr, jobs = _crossing_problems(cfg, n=2)
    calls = []

    def stop():
        calls.append(1)
        return len(calls) > 3

    for lanes in (1, 2):
        calls.clear()
        out = SolveLanes(make_backend("sqpmethod-daqp", pr), lanes).solve_all(jobs, stop)
        assert sum(o is not None for o in out) == 3 and len(calls) == len(jobs)
        assert all(o is None for o in out[3:]) or lanes == 2  # two lanes may take them in another order


def test_the_closed_loop_is_the_same_with_one_lane_or_two():
    """A 10-walker crossing, the planner as shipped (behind its check) but for its time
    budget: the same states, bit for bit, and the same counters."""
    from scenarios import Suite

    sc = Suite("circle-crossing", 1, 1, 10, "orca").scenario(0)
    sc = replace(sc, duration_s=8.0)
    logs, counters = {}, {}
    for n in (1, 2):
        # no time budget: what is compared is the answers, not how late a loaded machine gives
        # them (in one full-suite run a solve came back past the 0.5 s budget: over_budget 1)
        gpc = GPCController(preset("improved").with_overrides(solve_lanes=n, time_budget_s=1e6), sc.robot)
        logs[n] = simulate(sc, Shield(gpc, sc.robot, CheckSettings(trust_plans=True)), "gpc")
        counters[n] = dict(gpc.counters)
        assert gpc.lanes.count == n
    np.testing.assert_array_equal(np.asarray(logs[1].states), np.asarray(logs[2].states))
    differ = {k: (counters[1].get(k), counters[2].get(k)) for k in set(counters[1]) | set(counters[2])
              if counters[1].get(k) != counters[2].get(k)}
    assert not differ and counters[1]["full_multistarts"] > 0, differ


def test_a_forked_process_solves_on_its_own_threads():
    """A process forked after the lanes' threads started (a worker pool) inherits the
    executor but not its threads; it must still get its answers (it hung before)."""
    import multiprocessing as mp

    if "fork" not in mp.get_all_start_methods():
        pytest.skip("no fork on this platform")
    cfg = preset("paper")
    pr, jobs = _crossing_problems(cfg, n=1)
    lanes = SolveLanes(make_backend("sqpmethod-daqp", pr), 2)
    here = [r.cost for r, _ in lanes.solve_all(jobs)]  # the threads start here
    ctx = mp.get_context("fork")
    out = ctx.Queue()
    child = ctx.Process(target=lambda: out.put([r.cost for r, _ in lanes.solve_all(jobs)]))  # fork: not pickled
    child.start()
    there = out.get(timeout=60)
    child.join(timeout=10)
    assert there == here
