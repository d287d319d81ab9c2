"""One worker pool for every batch of independent tasks (dataset shards, on-policy
chunks, evaluation episodes): local worker processes, or a Ray cluster.

Tasks are ``fn(*args)`` calls whose results come back to the calling process, which writes
every file itself: workers only compute, so a killed run leaves nothing half-written (and,
on Linux, local workers die with their parent). Results are yielded as they finish, in any
order; a task that needs its place carries its index. At most ``2 workers`` tasks are in
flight, so a long queue costs no memory. The standard library only (Ray if asked for).
"""
from __future__ import annotations

import contextlib
import signal
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

__all__ = ["WorkerPool", "BACKENDS"]

BACKENDS = ("local", "ray")


@dataclass(frozen=True)
class WorkerPool:
    """Where tasks run.

    Attributes
    ----------
    workers : int
        Local worker processes (1 or less: in this process, one after the other), or the
        CPUs a locally started Ray instance gets.
    backend : {"local", "ray"}
        Local processes (forked, so each inherits what the parent already built) or Ray.
    address : str or None
        An existing Ray cluster's address (``ray`` only); None starts a local instance.
    """

    workers: int = 1
    backend: str = "local"
    address: str | None = None

    def imap_unordered(self, fn: Callable, tasks: Sequence[tuple]) -> Iterator:
        """``fn(*task)`` for every task, yielded as they finish (any order)."""
        if self.backend == "local":
            return _run_local(fn, list(tasks), self.workers)
        if self.backend == "ray":
            return _run_ray(fn, list(tasks), self.workers, self.address)
        raise ValueError(f"unknown backend {self.backend!r} (local or ray)")


def _worker_init():
    """Die with the parent (Linux), so that a killed run leaves no orphans computing."""
    try:
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C


def _run_local(fn, tasks: list, workers: int):
    """Yield ``fn(*task)`` results as they finish, at most ``2 workers`` in flight.

    The worker processes are forked here, before the caller starts any thread (a progress
    bar's monitor), so no child inherits a lock held by another thread."""
    if workers <= 1:
        return (fn(*t) for t in tasks)
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    ctx = mp.get_context("fork") if "fork" in mp.get_all_start_methods() else None
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init)
    queue = list(tasks)
    pending = {pool.submit(fn, *queue.pop(0)) for _ in range(min(2 * workers, len(queue)))}

    def results():
        nonlocal pending
        try:
            while queue or pending:
                while queue and len(pending) < 2 * workers:
                    pending.add(pool.submit(fn, *queue.pop(0)))
                done, pending = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    yield fut.result()
                del done
        finally:
            pool.shutdown(wait=True, cancel_futures=True)

    return results()


def _run_ray(fn, tasks: list, workers: int, address: str | None):
    try:
        import ray
    except ImportError:
        raise RuntimeError("--backend ray needs Ray (pip install 'gpcnav[distributed]')") from None
    started = False
    if not ray.is_initialized():
        import logging
        kw = dict(include_dashboard=False, logging_level=logging.ERROR, log_to_driver=False)
        if address:
            ray.init(address=address, **kw)
        else:
            ray.init(num_cpus=workers, **kw)
        started = True
    remote = ray.remote(num_cpus=1, max_retries=2)(fn)
    capacity = max(1, int(ray.cluster_resources().get("CPU", workers)))
    pending, queue = [], list(tasks)
    try:
        while queue or pending:
            while queue and len(pending) < 2 * capacity:
                pending.append(remote.remote(*queue.pop(0)))
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                yield ray.get(ref)
    finally:
        for ref in pending:
            with contextlib.suppress(Exception):
                ray.cancel(ref, force=True)
        if started:
            ray.shutdown()
