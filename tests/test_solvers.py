"""The solver backends (casadi_gpc.solvers) and the controller's time budget and injected
failures.

Each backend is checked against IPOPT, the planner's reference solver, on control problems
recorded from a closed-loop run: same success, same cost within 1e-6 relative. Failures
must be reported as failures, and the controller must turn a late or failed solve into its
counted fallback without raising.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import replace

import numpy as np
import pytest

from casadi_gpc import solvers
from gpcnav.benchmarks.solvers import record_problems
from casadi_gpc.config import PRESETS
from casadi_gpc.problem.cost import build_problem
from casadi_gpc.planner.gpc import SOLVE_SHARE, GPCController
from scenarios.simulator import simulate
from casadi_gpc.solvers import (COMPILE_EVENTS, FASTEST_SOLVER, SOLVER_NAMES, SolveResult, canonical_name,
                                constraint_violation_mps, make_backend, project_increments)
from scenarios import Faults, paper_scenarios

PAPER = PRESETS["paper"]
SAME = 1e-6


@pytest.fixture(scope="module")
def recorded():
    """The control problems of the GPC (reference IPOPT) on the paper's Fig. 7.2, preset paper."""
    sc = paper_scenarios()[1]
    rec = record_problems(sc, PAPER)
    problem = build_problem(PAPER, sc.robot)
    ref = make_backend("ipopt-warm", problem)
    ref_results = [ref.solve(q.p, q.u0, q.lam_x, q.lam_g) for q in rec.problems]
    return rec, problem, ref_results


def _cost(problem, u, p):
    return float(problem.cost_fn(u, p))


@pytest.mark.parametrize("name", ["ipopt-cold", "ipopt-warm-compiled", "sqpmethod-qrqp", "sqpmethod-daqp", "fatrop",
                                  "sqpmethod-daqp+fatrop"])
def test_backend_reaches_ipopts_cost_on_the_recorded_step_problems(recorded, name):
    rec, problem, ref_results = recorded
    backend = make_backend(name, problem)
    primary = [(q, r) for q, r in zip(rec.problems, ref_results) if q.primary]
    assert len(primary) == len(rec.log.compute_time_s) - 1 >= 20  # every step but the first
    worse = 0
    for q, ref in primary:
        assert ref.success
        res = backend.solve(q.p, q.u0, q.lam_x, q.lam_g)
        assert res.success, (q.step, res.status)
        assert np.all(np.isfinite(res.u)) and res.u.shape == (problem.n_u,)
        assert constraint_violation_mps(problem, res.u, q.p) <= 1e-8
        # the backend's own cost is the problem's cost at its answer
        assert res.cost == pytest.approx(_cost(problem, res.u, q.p), rel=1e-9, abs=1e-12)
        c, c_ref = _cost(problem, res.u, q.p), _cost(problem, ref.u, q.p)
        worse += c > c_ref * (1 + SAME)
    if name == "ipopt-cold":  # a cold barrier start may end in another local minimum: rarely
        assert worse <= 0.1 * len(primary)
    else:
        assert worse == 0


def test_fatrop_multiple_shooting_form_has_the_same_cost_as_single_shooting(recorded):
    """The MS problem sums the same stage terms: at the IPOPT answer both costs agree."""
    rec, problem, ref_results = recorded
    fat = make_backend("fatrop", problem)
    for q, ref in list(zip(rec.problems, ref_results))[::7]:
        # started exactly at IPOPT's optimum, fatrop stays there and reports the same cost
        res = fat.solve(q.p, ref.u)
        assert res.success
        assert res.cost == pytest.approx(ref.cost, rel=1e-7)
        np.testing.assert_allclose(res.u, ref.u, atol=1e-5)


def test_hybrid_solves_warm_starts_by_sqp_and_cold_starts_by_fatrop(recorded):
    rec, problem, _ = recorded
    hybrid = make_backend("sqpmethod-daqp+fatrop", problem)
    sqp, fat = make_backend("sqpmethod-daqp", problem), make_backend("fatrop", problem)
    warm = rec.primary[5]
    cold = next(q for q in rec.multistart if q.start.startswith("detour"))
    a, b = hybrid.solve(warm.p, warm.u0, warm.lam_x, warm.lam_g), sqp.solve(warm.p, warm.u0)
    np.testing.assert_array_equal(a.u, b.u)
    assert a.iterations == b.iterations
    a, b = hybrid.solve(cold.p, cold.u0), fat.solve(cold.p, cold.u0)
    np.testing.assert_array_equal(a.u, b.u)
    assert a.iterations == b.iterations
    assert "warm starts: sqpmethod-daqp" in hybrid.notes[0] and "cold starts: fatrop" in hybrid.notes[1]


def test_powell_answers_are_feasible_and_no_better_than_ipopt(recorded):
    rec, problem, ref_results = recorded
    powell = make_backend("powell", problem)
    for q, ref in [(q, r) for q, r in zip(rec.problems, ref_results) if q.primary][:6]:
        res = powell.solve(q.p, q.u0)
        assert constraint_violation_mps(problem, res.u, q.p) <= 1e-12
        assert res.evaluations > 0
        if res.success:
            # IPOPT's point is a local optimum of the same cost from the same start
            assert _cost(problem, res.u, q.p) >= ref.cost * (1 - 1e-6)
            assert res.cost == pytest.approx(_cost(problem, res.u, q.p), rel=1e-12)


def test_project_increments_keeps_both_limits_and_changes_nothing_feasible():
    v0 = np.array([0.7, -0.7])
    u = np.array([0.3, -0.3, 0.3, 0.1, -2.0, 2.0])
    out = project_increments(u, v0, dv_max=0.4, v_max=0.8)
    np.testing.assert_allclose(out, [0.1, -0.1, 0.0, 0.1, -0.4, 0.4])
    v = v0 + np.cumsum(out.reshape(-1, 2), axis=0)
    assert np.all(np.abs(v) <= 0.8 + 1e-15)
    ok = np.array([0.05, 0.0, -0.1, 0.05])
    np.testing.assert_array_equal(project_increments(ok, np.zeros(2), 0.4, 0.8), ok)


@pytest.mark.parametrize("name", SOLVER_NAMES)
def test_a_failed_solve_is_reported_as_failed_never_accepted(recorded, name):
    """A reference so far away that the cost overflows: every backend must say failed."""
    rec, problem, _ = recorded
    q = rec.primary[3]
    p = q.p.copy()
    p[problem.layout.slices()["ref"]] = 1e200
    res = make_backend(name, problem).solve(p, q.u0, q.lam_x, q.lam_g)
    assert res.success is False
    assert isinstance(res.status, str) and res.status


def test_non_finite_inputs_are_refused_before_the_solver_runs(recorded):
    rec, problem, _ = recorded
    q = rec.primary[3]
    p = q.p.copy()
    p[0] = np.nan
    for name in SOLVER_NAMES:
        res = make_backend(name, problem).solve(p, q.u0)
        assert res.success is False and res.status.startswith("refused")
        u0 = q.u0.copy()
        u0[1] = np.inf
        assert make_backend(name, problem).solve(q.p, u0).success is False


def test_names_and_aliases():
    assert canonical_name("ipopt") == "ipopt-warm"
    assert FASTEST_SOLVER in SOLVER_NAMES
    with pytest.raises(ValueError, match="unknown solver"):
        canonical_name("snopt")
    for name in PRESETS:
        assert canonical_name(PRESETS[name].solver) in SOLVER_NAMES


# --- compiling ----------------------------------------------------------------------------
SMALL = replace(PAPER, horizon=2, max_moving=1, max_static=0)  # a small NLP: compiles in ~1 s


def test_compiled_functions_are_cached_on_disk_and_give_the_same_answer(tmp_path, monkeypatch):
    if solvers.c_compiler() is None:
        pytest.skip("no C compiler on this machine")
    monkeypatch.setenv("GPCNAV_CACHE_DIR", str(tmp_path))
    problem = build_problem(SMALL)
    before = dict(COMPILE_EVENTS)
    first = make_backend("sqpmethod-daqp", problem)
    assert first.compiled and COMPILE_EVENTS["compiled"] == before["compiled"] + 1
    libs = list(tmp_path.glob("gpc_sqpmethod_*.so"))
    assert len(libs) == 1
    mtime = libs[0].stat().st_mtime_ns
    second = make_backend("sqpmethod-daqp", problem)  # a later run: from the cache
    assert second.compiled and COMPILE_EVENTS["cache_hits"] == before["cache_hits"] + 1
    assert COMPILE_EVENTS["compiled"] == before["compiled"] + 1
    assert libs[0].stat().st_mtime_ns == mtime
    plain = make_backend("sqpmethod-daqp", problem, compiled=False)
    x0 = np.array([0.0, 0.0, 0.0, 0.2, 0.2])
    ref = np.array([[0.4, 0.0, 0.0], [0.8, 0.1, 0.0]])
    p = problem.layout.pack(x0, ref)
    a, b = second.solve(p, np.zeros(4)), plain.solve(p, np.zeros(4))
    assert a.success and b.success
    np.testing.assert_allclose(a.u, b.u, atol=1e-10)
    assert a.cost == pytest.approx(b.cost, rel=1e-12)


def test_a_second_backend_of_the_same_settings_reuses_the_library_this_process_built(tmp_path, monkeypatch):
    """The process remembers the compiled library of each backend kind and settings
    (``compiling.known_library``): a second backend skips building the symbolic NLP and
    generating its code, loads the same library and solves bit for bit as the first; other
    settings, or another cache folder, are not taken for it."""
    if solvers.c_compiler() is None:
        pytest.skip("no C compiler on this machine")
    from casadi_gpc.solvers.compiling import known_library
    monkeypatch.setenv("GPCNAV_CACHE_DIR", str(tmp_path))
    problem = build_problem(SMALL)
    x0 = np.array([0.0, 0.0, 0.0, 0.2, 0.2])
    p = problem.layout.pack(x0, np.array([[0.4, 0.0, 0.0], [0.8, 0.1, 0.0]]))
    key = problem.code_key  # the settings and the robot's wheels (its radius is a parameter)
    assert key[0] == SMALL
    for name, what in (("sqpmethod-daqp", ("sqpmethod", "sqpmethod-daqp", "daqp", *key)),
                       ("fatrop", ("fatrop", "fatrop", *key))):
        assert known_library(what) is None
        first = make_backend(name, problem)
        lib = known_library(what)
        assert first.compiled and lib is not None and str(tmp_path) in lib
        hits = COMPILE_EVENTS["cache_hits"]
        second = make_backend(name, build_problem(SMALL))
        assert second.compiled and COMPILE_EVENTS["cache_hits"] == hits + 1
        assert any("(cached" in n for n in second.notes)
        a, b = first.solve(p, np.zeros(4)), second.solve(p, np.zeros(4))
        assert a.success and b.success
        np.testing.assert_array_equal(a.u, b.u)
        assert a.cost == b.cost
        assert known_library((*what[:-len(key)], replace(SMALL, lambda1=SMALL.lambda1 * 2), *key[1:])) is None
    monkeypatch.setenv("GPCNAV_CACHE_DIR", str(tmp_path / "elsewhere"))
    assert known_library(what) is None


def test_the_backup_compiles_beside_the_main_solver_and_is_then_compiled(tmp_path, monkeypatch, capsys):
    """On an empty cache the planner's backup (IPOPT, its functions compiled) is compiled in a
    process of its own while the main solver's compiles run, and so is the hybrid's fatrop
    while its SQP compiles: each compiler starts before the SQP's and is waited for after
    it, so a fresh install waits for the longest, not the sum. The backup is then compiled, a
    second controller of the same settings compiles nothing, and each background compile
    says so in one line."""
    if solvers.c_compiler() is None:
        pytest.skip("no C compiler on this machine")
    from pathlib import Path
    from casadi_gpc.solvers import compiling
    monkeypatch.setenv("GPCNAV_CACHE_DIR", str(tmp_path))
    events = []
    popen, finish = compiling.subprocess.Popen, compiling.Compile.finish

    def spy_popen(args, **kw):
        events.append(("start", Path(args[-2]).name.split("_")[1]))  # [cc, flags, sources, "-o", out, "-lm"]
        return popen(args, **kw)

    def spy_finish(self):
        running = self._proc is not None
        out = finish(self)
        if running:
            events.append(("finish", Path(self._lib or "gpc_failed_x").name.split("_")[1]))
        return out

    monkeypatch.setattr(compiling.subprocess, "Popen", spy_popen)
    monkeypatch.setattr(compiling.Compile, "finish", spy_finish)
    before = dict(COMPILE_EVENTS)
    ctl = GPCController(SMALL)
    assert sorted(events) == sorted([(w, p) for p in ("ipopt", "sqpmethod", "fatrop") for w in ("start", "finish")])
    at = {e: k for k, e in enumerate(events)}
    # the hybrid's fatrop beside its SQP, the backup beside both
    assert at[("start", "ipopt")] < at[("start", "fatrop")] < at[("start", "sqpmethod")]
    assert at[("finish", "sqpmethod")] < at[("finish", "fatrop")] < at[("finish", "ipopt")]
    assert ctl.solver_info["backup"] == "ipopt-warm-compiled" and ctl.backup.compiled
    assert COMPILE_EVENTS["compiled"] == before["compiled"] + 3
    assert len(list(tmp_path.glob("gpc_ipopt_*.so"))) == 1
    again = GPCController(SMALL)
    assert again.backup.compiled and COMPILE_EVENTS["compiled"] == before["compiled"] + 3
    err = capsys.readouterr().err.splitlines()
    for plugin in ("ipopt", "fatrop"):
        lines = [ln for ln in err if f"({plugin})" in ln]
        assert len(lines) == 1 and "beside the other solvers" in lines[0] and " done in " in lines[0]


def test_ipopt_compiled_takes_uncompiled_ipopts_steps_to_the_bit(recorded):
    """The backup's claim (docs/solvers.md, "Backup"): IPOPT on the compiled functions takes
    the same iterates as on CasADi's, so it answers every recorded problem (warm and cold
    starts) with the same iteration count, the same increments and the same cost, bit for
    bit; only faster (the ratio is asserted in the benchmark test below)."""
    if solvers.c_compiler() is None:
        pytest.skip("no C compiler on this machine")
    rec, problem, ref_results = recorded
    fast = make_backend("ipopt-warm-compiled", problem)
    assert fast.compiled
    for q, ref in zip(rec.problems, ref_results):
        r = fast.solve(q.p, q.u0, q.lam_x, q.lam_g)
        assert (r.success, r.iterations) == (ref.success, ref.iterations)
        np.testing.assert_array_equal(r.u, ref.u)
        assert r.cost == ref.cost


@pytest.mark.benchmark
def test_ipopt_compiled_is_faster_than_uncompiled_on_the_same_problems(recorded):
    """Ratios in one run: both interleaved on the same recorded problems. On this small NLP
    (the paper's preset) measured 1.23-1.31 times; on `improved`'s 2.3, on the crowd's with
    walls 4.5 (docs/solvers.md, "Backup")."""
    if solvers.c_compiler() is None:
        pytest.skip("no C compiler on this machine")
    rec, problem, _ = recorded
    fast, ref = make_backend("ipopt-warm-compiled", problem), make_backend("ipopt-warm", problem)
    t_fast, t_ref = [], []
    for _ in range(3):
        for q in rec.problems:
            t_ref.append(ref.solve(q.p, q.u0, q.lam_x, q.lam_g).solve_time_s)
            t_fast.append(fast.solve(q.p, q.u0, q.lam_x, q.lam_g).solve_time_s)
    assert np.median(t_ref) >= 1.1 * np.median(t_fast), (np.median(t_ref), np.median(t_fast))


def test_an_ipopt_planner_gets_no_ipopt_backup():
    """IPOPT compiled takes IPOPT's own steps: a planner solving with IPOPT, compiled or not,
    has no backup (it would fail where the main solver failed); any other solver has it."""
    from casadi_gpc.solvers import same_iterates
    assert same_iterates("ipopt", "ipopt-warm-compiled") and same_iterates("ipopt-warm-compiled", "ipopt-warm")
    assert not same_iterates("ipopt-cold", "ipopt-warm-compiled")
    assert not same_iterates(FASTEST_SOLVER, "ipopt-warm-compiled")
    for solver in ("ipopt-warm", "ipopt-warm-compiled"):
        ctl = GPCController(replace(SMALL, solver=solver))
        assert ctl.backup is None and ctl.solver_info["backup"] is None
    assert GPCController(replace(SMALL, solver="sqpmethod-daqp")).solver_info["backup"] == "ipopt-warm-compiled"


def test_a_cancelled_background_compile_stops_its_compiler_and_leaves_nothing(tmp_path, monkeypatch):
    """A controller whose main solver fails to build (an error, Ctrl-C) cancels the backup's
    compile instead of waiting for it: the compiler is stopped, the cache holds no library
    and no lock, and a later start compiles it whole."""
    if solvers.c_compiler() is None:
        pytest.skip("no C compiler on this machine")
    from casadi_gpc.solvers import start_backend
    from casadi_gpc.planner import tiers
    monkeypatch.setenv("GPCNAV_CACHE_DIR", str(tmp_path))
    problem = build_problem(SMALL)
    job = start_backend("ipopt-warm-compiled", problem)
    proc = job._proc
    assert proc is not None and proc.poll() is None  # compiling
    job.cancel()
    assert proc.poll() is not None and not list(tmp_path.glob("gpc_ipopt_*.so"))
    assert not [p for p in tmp_path.iterdir() if p.is_dir()]  # its temporary folder is gone
    lib, note = start_backend("ipopt-warm-compiled", problem).finish()  # the lock was released
    assert lib is not None and "compiled gpc_ipopt_" in note and len(list(tmp_path.glob("gpc_ipopt_*.so"))) == 1

    # the planner's tier: the main solver's build fails, the backup's compile is cancelled, the error is the caller's
    started = []

    def failing_backend(*a, **kw):
        raise KeyboardInterrupt

    def spy_start(name, problem, compiled=True):
        job = start_backend(name, problem, compiled)
        started.append(job)
        return job

    monkeypatch.setenv("GPCNAV_CACHE_DIR", str(tmp_path / "second"))
    monkeypatch.setattr(tiers, "make_backend", failing_backend)
    monkeypatch.setattr(tiers, "start_backend", spy_start)
    with pytest.raises(KeyboardInterrupt):
        tiers.build_tier(SMALL, problem.robot, 0.5, True, {}, "ipopt-warm-compiled")
    assert len(started) == 1 and started[0]._proc is None  # cancelled, not left running
    assert not list((tmp_path / "second").glob("gpc_ipopt_*.so"))


def test_without_a_compiler_the_backend_says_so_and_counts_the_fallback(tmp_path, monkeypatch):
    monkeypatch.setenv("GPCNAV_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("CC", "no-such-compiler-gpcnav")
    problem = build_problem(SMALL)
    before = COMPILE_EVENTS["fallbacks"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        backend = make_backend("ipopt-warm-compiled", problem)
    assert not backend.compiled
    assert COMPILE_EVENTS["fallbacks"] == before + 1
    assert any("no C compiler" in n for n in backend.notes)
    assert any("no C compiler" in str(w.message) for w in caught)
    p = problem.layout.pack(np.zeros(5), np.array([[0.4, 0.0, 0.0], [0.8, 0.0, 0.0]]))
    assert backend.solve(p, np.zeros(4)).success
    assert not list(tmp_path.glob("*.so"))


def test_a_cache_folder_that_cannot_be_made_is_said_as_no_compiler_is(tmp_path, monkeypatch):
    """$GPCNAV_CACHE_DIR under a file (or /proc) stopped every command that made the planner with
    mkdir's traceback; now the backend runs uncompiled and says why, as without a compiler."""
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("GPCNAV_CACHE_DIR", str(tmp_path / "file" / "cache"))
    problem = build_problem(SMALL)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        backend = make_backend("ipopt-warm-compiled", problem)
    assert not backend.compiled
    assert any("($GPCNAV_CACHE_DIR) cannot be made" in n for n in backend.notes)
    assert any("cannot be made" in str(w.message) for w in caught)


# --- the controller: budget, injected failures, same answers ---------------------------------
def _short(sc, duration_s=12.0):
    return replace(sc, duration_s=duration_s)


def test_a_step_whose_budget_is_spent_before_solving_falls_back_counted():
    sc = _short(paper_scenarios()[0])
    for solver in ("ipopt-warm", FASTEST_SOLVER):
        ctl = GPCController(replace(PAPER, solver=solver, time_budget_s=1e-9), sc.robot)
        log = simulate(sc, ctl, "gpc")
        steps = len(log.compute_time_s)
        assert steps == 8
        assert log.fallbacks == steps == ctl.counters["fallbacks"]
        assert ctl.counters["budget_skips"] >= steps and ctl.counters["solves"] == 0
        assert all(d.fallback and "time budget" in d.reason for d in log.decisions)


class _SlowBackend:
    """Delegates to a real backend after a pause: every answer arrives late."""

    def __init__(self, backend, pause_s):
        self.backend, self.pause_s = backend, pause_s
        self.calls = 0

    def solve(self, *args):
        import time
        self.calls += 1
        time.sleep(self.pause_s)
        return self.backend.solve(*args)


def test_an_answer_later_than_the_budget_is_not_used_and_the_fallback_is_counted():
    sc = _short(paper_scenarios()[0], 6.0)
    ctl = GPCController(replace(PAPER, time_budget_s=0.05), sc.robot)
    ctl.backend = slow = _SlowBackend(ctl.backend, 0.1)
    log = simulate(sc, ctl, "gpc")
    steps = len(log.compute_time_s)
    assert steps == 4
    # one solve per step starts in time, ends late, and is refused; the rest are not started
    assert slow.calls == ctl.counters["solves"] == ctl.counters["over_budget"] == steps
    assert ctl.counters["budget_skips"] > 0
    assert log.fallbacks == ctl.counters["fallbacks"] == steps
    assert all("over the time budget" in d.reason for d in log.decisions)


class _Failing:
    """A backend whose every solve fails."""

    def __init__(self):
        self.calls = 0

    def solve(self, p, u0, lam_x=None, lam_g=None):
        self.calls += 1
        return SolveResult(np.asarray(u0, float), float("nan"), False, "made to fail", 0)


def test_a_failed_solve_is_retried_by_the_backup_solver_and_counted():
    sc = _short(paper_scenarios()[1], 15.0)
    ctl = GPCController(replace(PAPER, solver=FASTEST_SOLVER), sc.robot)
    assert ctl.solver_info["backup"] == "ipopt-warm-compiled"
    ctl.backend = failing = _Failing()
    log = simulate(sc, ctl, "gpc")
    assert failing.calls == ctl.counters["solves"] == ctl.counters["backup_solves"] > 0
    assert ctl.counters["backup_successes"] == ctl.counters["backup_solves"] and log.fallbacks == 0
    # every answer came from the backup (IPOPT, its functions compiled where there is a
    # compiler): the run is uncompiled IPOPT's own, the same iterates
    ref = simulate(sc, GPCController(replace(PAPER, solver="ipopt-warm"), sc.robot), "gpc")
    np.testing.assert_allclose(np.asarray(log.states), np.asarray(ref.states), atol=1e-9)
    # without a backup the same failures are the planner's fallback
    bare = GPCController(replace(PAPER, solver=FASTEST_SOLVER), sc.robot, backup_solver=None)
    bare.backend = _Failing()
    log = simulate(sc, bare, "gpc")
    assert log.fallbacks == len(log.compute_time_s) == bare.counters["fallbacks"]
    assert bare.counters["backup_solves"] == 0 and bare.counters["failed_solves"] == bare.counters["solves"]


class _SlowFailing(_Failing):
    """A backend whose every solve fails after ``pause_s``."""

    def __init__(self, pause_s: float):
        super().__init__()
        self.pause_s = pause_s

    def solve(self, p, u0, lam_x=None, lam_g=None):
        import time
        time.sleep(self.pause_s)
        return super().solve(p, u0, lam_x, lam_g)


def test_the_backup_starts_only_while_half_the_budget_is_left():
    """A decision never outlives its step: the backup solver stops itself at half the time
    budget and starts only while half of it is left; a failure later than that goes
    straight to the fallback (``backup_skips``)."""
    sc = _short(paper_scenarios()[1], 6.0)
    budget = 0.1
    ctl = GPCController(replace(PAPER, solver=FASTEST_SOLVER, time_budget_s=budget, solve_lanes=1), sc.robot)
    assert ctl.backup is not None
    ctl.backend = failing = _SlowFailing(0.55 * budget)
    log = simulate(sc, ctl, "gpc")
    assert failing.calls > 0 and ctl.counters["backup_solves"] == 0
    assert ctl.counters["backup_skips"] == ctl.counters["failed_solves"] == ctl.counters["solves"] > 0
    assert log.fallbacks == len(log.compute_time_s)
    # a start begun within the budget may end past it, by one solve at most; nothing more runs
    assert max(log.compute_time_s) < budget + failing.pause_s
    quick = GPCController(replace(PAPER, solver=FASTEST_SOLVER, solve_lanes=1), sc.robot)  # 1.5 s: time enough
    quick.backend = _SlowFailing(0.0)
    simulate(sc, quick, "gpc")
    assert quick.counters["backup_solves"] > 0 and quick.counters.get("backup_skips", 0) == 0


def test_the_time_budget_defaults_to_a_share_of_the_sample_time():
    """The rest of the step is the check's behind the planner (and a solve that ends late)."""
    assert 0.0 < SOLVE_SHARE < 1.0
    ctl = GPCController(PAPER)
    assert ctl.time_budget_s == SOLVE_SHARE * PAPER.sample_time_s
    assert ctl.solver_info["time_budget_s"] == SOLVE_SHARE * PAPER.sample_time_s
    assert GPCController(replace(PAPER, time_budget_s=0.2)).time_budget_s == 0.2


class _Sleeping(_Failing):
    """A backend whose every solve takes ``pause_s`` (reported as its solve time) and succeeds
    with the start it was given."""

    def __init__(self, pause_s: float):
        super().__init__()
        self.pause_s = pause_s

    def solve(self, p, u0, lam_x=None, lam_g=None):
        import time
        self.calls += 1
        t0 = time.perf_counter()
        time.sleep(self.pause_s)
        u = np.asarray(u0, float)
        return SolveResult(u, float(np.sum(u * u)), True, "slept", 1, lam_x, lam_g, time.perf_counter() - t0)


def test_a_start_that_would_end_past_the_budget_is_not_begun():
    """Solves of 0.1 s against a 0.25 s budget, every guess at once: the third start (at 0.2 s)
    would end at 0.3 s; it is not begun (``budget_skips``), so no answer comes late and no step
    outlives its budget by a solve. The step's first solve is always tried (its time keeps the
    machine's speed current)."""
    sc = _short(paper_scenarios()[1], 6.0)
    ctl = GPCController(replace(PAPER, solver=FASTEST_SOLVER, time_budget_s=0.25, solve_lanes=1,
                                candidates="multistart"), sc.robot)
    ctl.backend = slow = _Sleeping(0.1)
    log = simulate(sc, ctl, "gpc")
    steps = len(log.compute_time_s)
    assert ctl.counters["over_budget"] == 0 and ctl.counters["budget_skips"] > 0
    assert slow.calls == ctl.counters["solves"] <= 2 * steps
    assert max(log.compute_time_s) < 0.25
    # the first start alone may end late (nothing to judge it by, or a slower machine): one solve at most
    late = GPCController(replace(PAPER, solver=FASTEST_SOLVER, time_budget_s=0.05, solve_lanes=1,
                                 candidates="multistart"), sc.robot)
    late.backend = _Sleeping(0.1)
    log = simulate(sc, late, "gpc")
    assert late.backend.calls == late.counters["over_budget"] == len(log.compute_time_s)


def test_injected_failures_follow_the_rng_and_are_counted_fallbacks():
    sc = _short(paper_scenarios()[1], 30.0)
    sc = replace(sc, faults=Faults(solver_failure_prob=0.3))
    ctl = GPCController(PAPER, sc.robot)
    log = simulate(sc, ctl, "gpc")  # the simulator calls inject_failures with its own rng
    steps = len(log.compute_time_s)
    draws = np.random.default_rng([sc.sensing.seed, 7]).random(steps)
    expected = int(np.sum(draws < 0.3))
    assert 0 < expected < steps
    assert ctl.counters["injected_failures"] == log.events["injected_failures"] == expected
    assert log.fallbacks == expected
    assert [d.fallback for d in log.decisions] == list(draws < 0.3)
    assert all("injected solver failure" in d.reason for d in log.decisions if d.fallback)


def test_inject_failures_with_probability_one_falls_back_every_step():
    sc = _short(paper_scenarios()[0])
    ctl = GPCController(PAPER, sc.robot)
    ctl.reset()
    ctl.inject_failures(1.0, np.random.default_rng(0))
    from casadi_gpc.types import Observation
    for k in range(3):
        d = ctl.decide(Observation(k * 1.5, sc.robot_start, sc.reference))
        assert d.fallback and math.isfinite(d.v_right_mps) and math.isfinite(d.v_left_mps)
    assert ctl.counters["injected_failures"] == ctl.counters["fallbacks"] == 3
    assert ctl.counters["solves"] == 0
    with pytest.raises(ValueError):
        ctl.inject_failures(1.5)


def test_the_fast_solver_drives_the_paper_scenario_like_ipopt():
    sc = paper_scenarios()[1]
    logs = {}
    for solver in ("ipopt-warm", FASTEST_SOLVER):
        ctl = GPCController(replace(PAPER, solver=solver), sc.robot)
        assert ctl.solver_name == solver
        logs[solver] = simulate(sc, ctl, "gpc")
    a, b = logs["ipopt-warm"], logs[FASTEST_SOLVER]
    assert a.outcome == b.outcome == "reached_goal"
    assert a.fallbacks == b.fallbacks == 0
    np.testing.assert_allclose(np.asarray(b.states), np.asarray(a.states), atol=1e-5)


@pytest.mark.slow
@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_the_fast_solver_gives_the_same_outcomes_on_all_paper_scenarios(preset):
    cfg = PRESETS[preset]
    for sc in paper_scenarios():
        runs = [simulate(sc, GPCController(replace(cfg, solver=s), sc.robot), "gpc")
                for s in ("ipopt-warm", cfg.solver)]
        assert runs[0].outcome == runs[1].outcome == "reached_goal"
        assert runs[1].fallbacks == runs[0].fallbacks == 0
        if preset == "paper":  # measured: the very same runs (under improved, from a guess the
            # hybrid's fatrop finds a cheaper plan than IPOPT at one step of 7.2 and 7.3: same
            # outcome, another path; docs/solvers.md)
            np.testing.assert_allclose(np.asarray(runs[1].states), np.asarray(runs[0].states), atol=1e-5)


@pytest.mark.benchmark
def test_chosen_solver_is_at_least_twice_as_fast_as_warm_ipopt_at_the_same_cost(recorded):
    """Ratios in one run: both solvers interleaved on the same recorded step problems."""
    rec, problem, _ = recorded
    fast, ref = make_backend(FASTEST_SOLVER, problem), make_backend("ipopt-warm", problem)
    t_fast, t_ref = [], []
    for _ in range(3):
        for q in rec.primary:
            a = ref.solve(q.p, q.u0, q.lam_x, q.lam_g)
            b = fast.solve(q.p, q.u0, q.lam_x, q.lam_g)
            assert a.success and b.success
            assert _cost(problem, b.u, q.p) <= _cost(problem, a.u, q.p) * (1 + SAME)
            t_ref.append(a.solve_time_s)
            t_fast.append(b.solve_time_s)
    assert np.median(t_ref) >= 2.0 * np.median(t_fast), (np.median(t_ref), np.median(t_fast))


def test_simulate_takes_the_solver_option_and_says_which_solver_ran(tmp_path):
    import json
    import subprocess
    import sys
    out = tmp_path / "RUN.json"
    scenario = str(paper_scenarios()[0].source)
    proc = subprocess.run([sys.executable, "-m", "gpcnav", "simulate", scenario, "--preset", "paper",
                           "--solver", "ipopt", "--out", str(out)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_text())
    assert doc["solver"]["name"] == "ipopt-warm" and doc["solver"]["time_budget_s"] == SOLVE_SHARE * PAPER.sample_time_s
    bad = subprocess.run([sys.executable, "-m", "gpcnav", "simulate", scenario, "--solver", "snopt"],
                         capture_output=True, text=True)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "snopt" in bad.stderr
