"""One worker pool for every batch of independent tasks (dataset shards, on-policy
chunks, evaluation episodes): local worker processes, or a Ray cluster.

A Ray cluster named by an address is first reached with a plain TCP connection that gives
up after :data:`CONNECT_TIMEOUT_S` (``$GPCNAV_RAY_CONNECT_TIMEOUT_S``, default 5 s): a cluster
that is not there is a one-line :class:`ClusterUnavailable` within seconds, not Ray's own
retry loop (minutes). :meth:`WorkerPool.connected` connects before any work, so a command can
refuse an absent cluster before it makes a folder or builds a solver.

Tasks are ``fn(*args)`` calls whose results come back to the calling process, which writes
every file itself: workers only compute, so a killed run leaves nothing half-written (and,
on Linux, local workers die with their parent). A local worker that dies on its own (killed:
out of memory, a signal) costs the tasks then in flight one more run each in new workers, said in
one line, up to :data:`WORKER_RESTARTS` times a batch; then :class:`WorkersDied`. Results are
yielded as they finish, in any order; a task that needs its place carries its index. At most ``2 workers`` tasks are in
flight, so a long queue costs no memory. The standard library only (Ray if asked for).
"""
from __future__ import annotations

import contextlib
import math
import os
import signal
import socket
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

__all__ = ["WorkerPool", "BACKENDS", "ClusterUnavailable", "WorkersDied", "CONNECT_TIMEOUT_S", "connect_timeout_s",
           "check_reachable", "WORKER_RESTARTS", "abandon_live_pools"]

BACKENDS = ("local", "ray")

CONNECT_TIMEOUT_S = 5.0
"""How long a Ray cluster's address may take to accept a TCP connection before the run is
refused (s), unless ``$GPCNAV_RAY_CONNECT_TIMEOUT_S`` says otherwise (:func:`connect_timeout_s`).
A cluster on a network answers in milliseconds; Ray itself retries for minutes."""


def connect_timeout_s() -> float:
    """``$GPCNAV_RAY_CONNECT_TIMEOUT_S`` (s), or :data:`CONNECT_TIMEOUT_S` where it is unset;
    one that is not a positive number is a :class:`ClusterUnavailable` naming it (it was read at
    import: "abc" stopped every command with a traceback, ray or not, and -1 a Ray run)."""
    text = os.environ.get("GPCNAV_RAY_CONNECT_TIMEOUT_S") or ""
    if not text.strip():
        return CONNECT_TIMEOUT_S
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise ClusterUnavailable(f"$GPCNAV_RAY_CONNECT_TIMEOUT_S must be a positive number of seconds, got {text!r}")
    return value


class ClusterUnavailable(RuntimeError):
    """The Ray cluster of ``--address`` cannot be reached (or Ray cannot start); the message
    is one line."""


class WorkersDied(RuntimeError):
    """Local worker processes died abruptly (killed: out of memory, a signal; a crash in compiled
    code) more than :data:`WORKER_RESTARTS` times in one batch, or on Ray a task's workers beyond
    its retries, or Ray itself under the run; the message is one line."""


WORKER_RESTARTS = 2
"""How many times a batch of local tasks goes on in new worker processes after one died abruptly
(Ray retries a task as often: ``max_retries``). The tasks then in flight run again from the start:
a task computes and returns, so running it again gives what it would have given."""


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

    @contextlib.contextmanager
    def connected(self):
        """Connect to the Ray cluster (or start a local Ray instance) now, and shut it down
        on leaving; for local processes, nothing. Raises :class:`ClusterUnavailable` (one
        line, within :data:`CONNECT_TIMEOUT_S` for an address) before any work."""
        if self.backend != "ray":
            yield self
            return
        started = _ray_init(self.workers, self.address)
        try:
            yield self
        finally:
            if started:
                import ray
                ray.shutdown()


def _host_port(address: str) -> tuple[str, int] | None:
    """``(host, port)`` of a Ray address (``host:port``, ``ray://host:port``, ``[v6]:port``),
    or None for the words Ray knows (``auto``, ``local``) and anything without a port."""
    rest = address.split("://", 1)[-1].rstrip("/")
    host, sep, port = rest.rpartition(":")
    if not sep or not port.isdigit() or not host:
        return None
    return host.strip("[]"), int(port)


def check_reachable(address: str, timeout_s: float | None = None) -> None:
    """Refuse (:class:`ClusterUnavailable`) an address where nothing accepts a TCP connection
    within ``timeout_s`` (default :func:`connect_timeout_s`)."""
    hp = _host_port(address)
    if hp is None:
        return
    timeout_s = connect_timeout_s() if timeout_s is None else timeout_s
    try:
        with socket.create_connection(hp, timeout=timeout_s):
            pass
    except socket.timeout:
        raise ClusterUnavailable(f"no Ray cluster at {address}: no answer within {timeout_s:g} s "
                                 "($GPCNAV_RAY_CONNECT_TIMEOUT_S)") from None
    except OSError as exc:
        raise ClusterUnavailable(f"no Ray cluster at {address}: {exc.strerror or exc}") from None


def _ray_init(workers: int, address: str | None) -> bool:
    """Connect to Ray (or start it) unless already connected; True if this call did."""
    try:
        import ray
    except ImportError:
        raise ClusterUnavailable("--backend ray needs Ray (pip install 'gpcnav[distributed]')") from None
    if ray.is_initialized():
        return False
    import logging
    kw = dict(include_dashboard=False, logging_level=logging.ERROR, log_to_driver=False)
    if address:
        check_reachable(address)
    try:
        with _own_sigterm(ray):
            if address:
                ray.init(address=address, **kw)
            else:
                ray.init(num_cpus=workers, **kw)
    except Exception as exc:  # noqa: BLE001 - whatever Ray raises, the user gets one line
        text = " ".join(str(exc).split()) or type(exc).__name__
        where = f"the Ray cluster at {address}" if address else "a local Ray instance"
        raise ClusterUnavailable(f"cannot use {where}: {text}") from None
    return True


@contextlib.contextmanager
def _own_sigterm(ray):
    """``ray.init`` inside, SIGTERM left to the caller's handler (CONTRACT.md: a stop says so in one
    line, exit 143; the caller's stop shuts Ray down). Ray's init put its own in, ``sys.exit(15)``, and
    its C++ crash handler, which takes SIGTERM too and which Ray's shutdown leaves at the default
    action: a SIGTERM'd ``evaluate --backend ray`` ended with exit status 15, or was killed by the
    stop's repeated signal while Ray shut down (143), with no line. This process goes without Ray's
    crash handler (its stack trace of a crash in Ray's C++ code); the workers keep theirs."""
    import threading
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.getsignal(signal.SIGTERM)
    private = getattr(ray, "_private", None)
    utils, constants = getattr(private, "utils", None), getattr(private, "ray_constants", None)
    setter = getattr(utils, "set_sigterm_handler", None)
    crash_handler = getattr(constants, "RAY_DISABLE_FAILURE_SIGNAL_HANDLER", None)
    if setter is not None:
        utils.set_sigterm_handler = lambda handler: None
    if crash_handler is not None:  # read as this process connects: its workers are made with theirs
        constants.RAY_DISABLE_FAILURE_SIGNAL_HANDLER = True
    try:
        yield
    finally:
        if setter is not None:
            utils.set_sigterm_handler = setter
        if crash_handler is not None:
            constants.RAY_DISABLE_FAILURE_SIGNAL_HANDLER = crash_handler
        signal.signal(signal.SIGTERM, previous)


def _worker_init():
    """Die with the parent (Linux), so that a killed run leaves no orphans computing."""
    try:
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # and stops as on Ctrl-C on SIGTERM (gpcnav.cli); a worker just ends


def _run_local(fn, tasks: list, workers: int):
    """Yield ``fn(*task)`` results as they finish, at most ``2 workers`` in flight.

    The worker processes are forked here, before the caller starts any thread (a progress
    bar's monitor), so no child inherits a lock held by another thread."""
    if workers <= 1:
        return (fn(*t) for t in tasks)
    import multiprocessing as mp
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool
    from .io import stop_requested

    def new_pool(method: str):
        ctx = mp.get_context(method) if method in mp.get_all_start_methods() else None
        made = ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_worker_init)
        _LIVE.add(made)
        return made

    pool = new_pool("fork")
    queue = list(tasks)
    pending = {}  # future -> its task
    for _ in range(min(2 * workers, len(queue))):
        task = queue.pop(0)
        pending[pool.submit(fn, *task)] = task

    def results():
        nonlocal pool
        restarts = 0
        try:
            while queue or pending:
                broken = None  # the pool's BrokenProcessPool, once one of its workers died
                while queue and len(pending) < 2 * workers and not broken:
                    try:
                        fut = pool.submit(fn, *queue[0])
                    except BrokenProcessPool as exc:  # it broke since the last wait
                        broken = exc
                    else:
                        pending[fut] = queue.pop(0)
                if not broken:
                    done, _ = wait(pending, return_when=FIRST_COMPLETED)
                    for fut in done:
                        if isinstance(fut.exception(), BrokenProcessPool):
                            broken = fut.exception()
                            continue
                        result = fut.result()  # (a task's own error is raised here, as it was)
                        del pending[fut]
                        yield result
                    del done
                if broken:
                    if stop_requested():  # our own stop ended the workers (SIGTERM to the group): said as a stop
                        raise broken
                    workers_then = list((getattr(pool, "_processes", None) or {}).values())
                    pool.shutdown(wait=True, cancel_futures=True)
                    _LIVE.discard(pool)
                    how = _deaths(workers_then)
                    restarts += 1
                    lost = list(pending.values())
                    n = f"{len(lost)} task{'s' if len(lost) != 1 else ''}"
                    if restarts > WORKER_RESTARTS:
                        raise WorkersDied(f"worker processes died {restarts} times ({how}); the last time {n} "
                                          f"were in flight")
                    print(f"worker pool: a worker process died ({how}); the {n} then in flight run again in new "
                          "workers", file=sys.stderr)
                    # started afresh (spawn): a fork now would copy the caller's threads' locks
                    pool = new_pool("spawn")
                    queue[:0] = lost
                    pending.clear()
        except BaseException:  # a stop, a task's error, the caller gone: the workers' work is not wanted
            _abandon(pool)
            raise
        pool.shutdown(wait=True)
        _LIVE.discard(pool)

    return results()


_LIVE: set = set()
"""The local pools made and not yet shut down (:func:`abandon_live_pools`)."""


def abandon_live_pools() -> None:
    """End every local pool not yet shut down (:func:`_abandon`): a stop that came before a pool's
    results were first asked for (the pool is made first, before the caller's threads start) left
    it running its tasks, and the interpreter's exit waited for all of them (``gpcnav.cli.main``
    calls this as a command ends)."""
    for pool in list(_LIVE):
        _abandon(pool)


def _abandon(pool) -> None:
    """End ``pool`` at once: its workers terminated (they only compute; nothing of theirs is kept),
    its queued tasks cancelled, nothing waited for. A stop that waited for the workers to finish their
    tasks (``shutdown(wait=True)``) could be broken off by the stop's repeated signal (gpcnav.cli)
    on a loaded machine, and the interpreter's exit then waited for ever on workers that never got
    their end (a SIGTERM'd ``evaluate`` hung after its line, 3 runs in 3 beside two busy loops)."""
    _LIVE.discard(pool)
    for p in list((getattr(pool, "_processes", None) or {}).values()):
        with contextlib.suppress(Exception):
            p.terminate()
    pool.shutdown(wait=False, cancel_futures=True)


def _deaths(processes) -> str:
    """How a broken pool's worker ``processes`` ended (joined), in words (exit codes: -N a signal)."""
    codes = sorted({p.exitcode for p in processes if p.exitcode not in (None, 0)})
    if len(codes) > 1 and -signal.SIGTERM in codes:  # the others, which the pool itself stops once one died
        codes.remove(-signal.SIGTERM)
    if not codes:
        return "ended abruptly"
    words = []
    for c in codes:
        if c < 0:
            try:
                words.append(f"killed by {signal.Signals(-c).name}" + (": out of memory?" if -c == signal.SIGKILL else ""))
            except ValueError:
                words.append(f"killed by signal {-c}")
        else:
            words.append(f"exit status {c}")
    return ", ".join(words)


def _run_ray(fn, tasks: list, workers: int, address: str | None):
    started = _ray_init(workers, address)
    import ray
    remote = ray.remote(num_cpus=1, max_retries=WORKER_RESTARTS)(fn)
    capacity = max(1, int(ray.cluster_resources().get("CPU", workers)))
    pending, queue = [], list(tasks)
    try:
        while queue or pending:
            while queue and len(pending) < 2 * capacity:
                pending.append(remote.remote(*queue.pop(0)))
            done, pending = ray.wait(pending, num_returns=1)
            for ref in done:
                yield _ray_result(ray, ref)
    finally:
        for ref in pending:
            with contextlib.suppress(Exception):
                ray.cancel(ref, force=True)
        if started:
            ray.shutdown()


def _ray_result(ray, ref):
    """``ray.get(ref)``, its failures as the local backend's: a task's own error raised as itself
    (Ray's wrapper said it over several lines, the remote traceback in colour), and a task whose
    workers died beyond Ray's retries, or Ray failing under the run (its raylet killed),
    :class:`WorkersDied` in one line (they were Ray's tracebacks)."""
    errors = ray.exceptions
    try:
        return ray.get(ref)
    except errors.RayTaskError as exc:
        if isinstance(exc.cause, BaseException):
            raise exc.cause from None
        raise
    except (errors.WorkerCrashedError, errors.OutOfMemoryError) as exc:
        how = "killed by Ray's memory monitor" if isinstance(exc, errors.OutOfMemoryError) else "killed or crashed"
        raise WorkersDied(f"Ray workers died {WORKER_RESTARTS + 1} times running one task ({how}; Ray retries a "
                          f"task {WORKER_RESTARTS} times)") from None
    except errors.RayError as exc:  # Ray itself under the run: its raylet or node died, an object lost
        first = (str(exc).strip().splitlines() or [""])[0]
        raise WorkersDied(f"Ray failed under the run: {type(exc).__name__}: {first}") from None
