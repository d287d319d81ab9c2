"""Several starts of one NLP solved at once, in threads.

A tick of the planner solves one NLP from several starts (the kept candidates, the fixed
guesses of a multi-start). The solves are independent, and CasADi releases the GIL while a
buffered function evaluates (:mod:`casadi_gpc.buffered`), so two solver buffers (two CasADi
memories of one compiled solver) run in two threads at once. Measured on a 10-walker crowd's
recorded problems (``improved``): 44 warm SQP solves 81 -> 43 ms, 270 cold fatrop solves
1.07 -> 0.60 s in two threads, the same numbers bit for bit.

:class:`SolveLanes` holds one backend per lane (the controller's and its
:meth:`~casadi_gpc.solvers.base.Backend.fork`\\ s) and hands each solve to a free lane. Each
solve is independent of the others, so the answers do not depend on the number of lanes or
on which lane solved what. A backend that cannot fork (IPOPT, Powell, anything that calls
back into Python) gets one lane.
"""
from __future__ import annotations

import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor

from ..solvers import Backend, SolveResult

__all__ = ["SolveLanes"]


class SolveLanes:
    """``lanes`` backends of one problem: ``backend`` and its forks (one lane when it does
    not fork). :meth:`solve_all` solves a list of starts: the calling thread on the first
    lane, a pool thread on each other, each taking the next start not yet taken."""

    def __init__(self, backend: Backend, lanes: int = 1):
        if int(lanes) != lanes or lanes < 1:
            raise ValueError(f"solve lanes must be a whole number >= 1, got {lanes}")
        self.backends = [backend]
        fork = getattr(backend, "fork", None)  # a stand-in without one gets one lane
        for _ in range(int(lanes) - 1 if fork is not None else 0):
            twin = fork()
            if twin is None:
                break
            self.backends.append(twin)
        self._pool, self._pool_pid = None, 0

    @property
    def count(self) -> int:
        return len(self.backends)

    def solve_all(self, jobs: list[tuple], stop=None, timed=None) -> list[tuple[SolveResult, float] | None]:
        """Each job ``(p, u0, lam_x, lam_g)`` solved, in the order given, with the
        ``time.perf_counter()`` at which its answer was there; None for a job not started
        because ``stop()`` (checked as each job is about to start) said so. ``timed(seconds)``
        is told each solve's wall time as it ends (from the lane's thread)."""
        if len(self.backends) == 1 or len(jobs) < 2:
            return [_run(self.backends[0], job, stop, timed) for job in jobs]
        if self._pool is None or self._pool_pid != os.getpid():
            # a process forked from this one (a worker pool) inherits the executor but not its
            # threads: work handed to it would wait for ever, so each process makes its own
            self._pool = ThreadPoolExecutor(len(self.backends) - 1, thread_name_prefix="gpc-lane")
            self._pool_pid = os.getpid()
        results: list = [None] * len(jobs)
        order = iter(range(len(jobs)))
        lock = threading.Lock()

        def drain(backend):
            while True:
                with lock:
                    i = next(order, None)
                if i is None:
                    return
                results[i] = _run(backend, jobs[i], stop, timed)

        helpers = [self._pool.submit(drain, b) for b in self.backends[1:]]
        drain(self.backends[0])  # the first start (the likeliest answer) is taken here, at once
        for h in helpers:
            h.result()
        return results


def _run(backend: Backend, job, stop, timed) -> tuple[SolveResult, float] | None:
    if stop is not None and stop():
        return None
    t0 = time.perf_counter()
    r = backend.solve(*job)
    done = time.perf_counter()
    if timed is not None:
        timed(done - t0)
    return r, done
