"""Labelled datasets on disk: shards, a manifest, a resumable writer, local and Ray workers.

A dataset directory holds ``manifest.json`` and shard files ``shard-00000.npz``, ... (plain
numpy arrays, no pickle). Work is cut into shards whose contents depend only on
``(spec, shard index)``: shard ``i`` draws its situations from the generator seeded with
``[seed, i]`` and keeps drawing until it holds its quota of converged samples. So a run that
is stopped at any point (kill -9 included) and started again with the same arguments finds
the finished shards on disk, redoes only the others, and ends with exactly the samples asked
for, none twice. A shard is written to a temporary name in the same directory and renamed
(atomic on POSIX), so it is there whole or not at all; the manifest is rewritten the same
way after every shard. The parent process writes every file; workers only compute, so a
killed run leaves nothing half-written (and, on Linux, its workers die with it).

Shard arrays (``n`` samples, ``H`` horizon, ``F`` features):

=====================  ============  ==================================================
key                    shape         meaning
=====================  ============  ==================================================
``features``           (n, F)        the layout's inputs (``manifest["feature_names"]``)
``labels``             (n, 2)        GPC first control: right, left wheel speed, m/s
``plan_wheels_mps``    (n, H, 2)     the GPC's whole planned wheel-speed sequence, m/s
``cost``               (n,)          the optimal cost
``status``             (n,)          the solver status of the winning candidate
``guess``              (n,)          which initial guess won
``iterations``         (n,)          solver iterations of the winner
``solver``             (n,)          the solver that answered (the fallback solver where
                                     the labelling solver found no converged answer)
``candidate_costs``    (n, G)        cost from each initial guess (manifest ``guess_names``), NaN if failed
``mirror``             (n,)          True for the mirror image of the previous sample
``situation_id``       (n,)          unique per situation; a sample and its mirror share it
``sample_id``          (n,)          unique per sample (2 situation_id + mirror)
``mirror_check_mps``   (n,)          for checked situations: max |mirrored label - GPC
                                     answer on the mirrored situation| of the first
                                     control, m/s; NaN where not checked. Above 1e-6
                                     the two sides found different optima, and the
                                     cheaper one is kept for both samples (counted in
                                     ``mirror_check_replaced``)
=====================  ============  ==================================================

plus ``spec_id`` (which request made it) and ``stats_json`` (the shard's counters).

Backends: ``local`` runs worker processes on this machine (the solver is built once per
worker); ``ray`` submits the same shard tasks to a Ray cluster (``address`` of an existing
one, or a local instance), and the driver writes the results.
"""
from __future__ import annotations

import contextlib
import hashlib
import json
import math
import signal
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from casadi_gpc.config import PlannerConfig
from casadi_gpc.io import atomic_file, json_default
from casadi_gpc.robot import RobotParams

from .features import FeatureLayout, compute_features, layout_from_dict, mirror_features
from .labels import GUESS_NAMES, LABEL_NAMES, MIRROR_GUESS_ORDER, Labeller, mirror_guess, mirror_label
from .sampler import SamplerSettings, sample_situation

__all__ = [
    "DATASET_FORMAT", "DatasetSpec", "DatasetMismatch", "label_shard", "generate", "read_manifest", "read_shard",
    "load_dataset", "LoadedDataset", "collect_on_policy", "collect_on_policy_parallel", "append_part", "ARRAY_KEYS",
    "prepare_labeller",
]

DATASET_FORMAT = "gpcnav-dataset/1"
MANIFEST = "manifest.json"
LOCK = ".lock"
ARRAY_KEYS = ("features", "labels", "plan_wheels_mps", "cost", "status", "guess", "iterations", "candidate_costs",
              "solver", "mirror", "situation_id", "sample_id", "mirror_check_mps")
_PART_STRIDE = 10 ** 12   # situation ids: part * stride + shard * shard stride + index
_SHARD_STRIDE = 10 ** 6
MIRROR_TOLERANCE_MPS = 1e-6


class DatasetMismatch(ValueError):
    """The directory holds a dataset made with other arguments, or is in use."""


@dataclass(frozen=True)
class DatasetSpec:
    """Everything that decides a dataset's contents (its ``spec_id`` is a hash of it)."""

    samples: int
    """Labelled samples wanted, mirror samples included."""
    config: PlannerConfig
    layout: FeatureLayout
    seed: int = 0
    robot: RobotParams = field(default_factory=RobotParams)
    solver: str = "ipopt"
    shard_size: int = 1000
    """Samples per shard (even, so that a situation and its mirror share a shard)."""
    mirror: bool = True
    """Add the mirror image of every situation as a second sample."""
    mirror_check_every: int = 25
    """Solve the mirrored situation for real for every this-many-th situation (0: never)."""
    sampler: SamplerSettings = field(default_factory=SamplerSettings)

    def __post_init__(self):
        if self.samples < 1:
            raise ValueError(f"samples must be at least 1, got {self.samples}")
        if self.shard_size < 2 or self.shard_size % 2 or self.shard_size > _SHARD_STRIDE:
            raise ValueError(f"shard size must be an even number in [2, {_SHARD_STRIDE}], got {self.shard_size}")
        if self.layout.horizon != self.config.horizon:
            raise ValueError(f"layout horizon {self.layout.horizon} != planner horizon {self.config.horizon}")

    @property
    def n_shards(self) -> int:
        return -(-self.samples // self.shard_size)

    def shard_samples(self, index: int) -> int:
        return min(self.shard_size, self.samples - index * self.shard_size)

    def request(self) -> dict:
        """What a resumed run must agree on."""
        return {
            "samples": self.samples, "seed": self.seed, "preset": self.config.name,
            "planner_config": self.config.to_dict(), "feature_layout": self.layout.to_dict(),
            "robot": self.robot.to_dict(), "solver": self.solver, "shard_size": self.shard_size,
            "mirror": self.mirror, "mirror_check_every": self.mirror_check_every, "sampler": asdict(self.sampler),
        }

    @property
    def spec_id(self) -> str:
        return _digest(self.request())


def _digest(doc) -> str:
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()[:16]


# --------------------------------------------------------------------------------------
# workers: one labeller per process, built on first use
# --------------------------------------------------------------------------------------
_LABELLERS: dict = {}


def prepare_labeller(spec: "DatasetSpec") -> Labeller:
    """Build (once per process) the labeller ``spec`` needs; raises ValueError for an
    unknown solver. Local workers are forked after this, so they inherit it built."""
    return _labeller(spec.config, spec.robot, spec.solver)


def _labeller(config: PlannerConfig, robot: RobotParams, solver: str) -> Labeller:
    key = (config, robot, solver)
    if key not in _LABELLERS:
        _LABELLERS[key] = Labeller(config, robot, solver)
    return _LABELLERS[key]


class _ShardBuilder:
    """Accumulates samples of one shard as arrays of known size."""

    def __init__(self, n: int, F: int, H: int):
        self.n, self.k = n, 0
        self.a = {
            "features": np.empty((n, F)), "labels": np.empty((n, 2)), "plan_wheels_mps": np.empty((n, H, 2)),
            "cost": np.empty(n), "status": [], "guess": [], "solver": [], "iterations": np.empty(n, dtype=np.int32),
            "candidate_costs": np.empty((n, len(GUESS_NAMES))), "mirror": np.zeros(n, dtype=bool),
            "situation_id": np.empty(n, dtype=np.int64), "sample_id": np.empty(n, dtype=np.int64),
            "mirror_check_mps": np.full(n, np.nan),
        }

    @property
    def full(self) -> bool:
        return self.k >= self.n

    def add(self, features, plan, label, situation_id: int, mirror: bool, check=float("nan")) -> None:
        a, k = self.a, self.k
        a["features"][k] = features
        a["labels"][k] = plan[0]
        a["plan_wheels_mps"][k] = plan
        a["cost"][k] = label.cost
        a["status"].append(label.status)
        a["solver"].append(label.solver)
        a["guess"].append(mirror_guess(label.guess) if mirror else label.guess)
        a["iterations"][k] = label.iterations
        a["candidate_costs"][k] = label.candidate_costs[MIRROR_GUESS_ORDER] if mirror else label.candidate_costs
        a["mirror"][k] = mirror
        a["situation_id"][k] = situation_id
        a["sample_id"][k] = 2 * situation_id + int(mirror)
        a["mirror_check_mps"][k] = check
        self.k += 1

    def arrays(self) -> dict:
        out = dict(self.a)
        out["status"] = np.array(out["status"], dtype=str)
        out["guess"] = np.array(out["guess"], dtype=str)
        out["solver"] = np.array(out["solver"], dtype=str)
        return out


def _new_stats() -> dict:
    return {"situations": 0, "not_converged": 0, "answered_by_fallback_solver": 0, "failure_statuses": {}, "solves": 0,
            "solve_time_s": 0.0,
            "mirror_checked": 0, "mirror_check_failed": 0, "mirror_max_diff_mps": 0.0,
            "mirror_over_tolerance": 0, "mirror_check_replaced": 0, "features": {}, "elapsed_s": 0.0}


def _label_situations(builder: _ShardBuilder, stats: dict, situations, layout: FeatureLayout, labeller: Labeller,
                      mirror: bool, check_every: int, id_base: int) -> None:
    """Label situations from an iterator into ``builder`` until it is full."""
    j = 0
    for sit in situations:
        if builder.full:
            break
        label = labeller.label(sit)
        stats["situations"] += 1
        if label.converged and label.solver != labeller.solver:
            stats["answered_by_fallback_solver"] += 1
        stats["solves"] += label.solves
        stats["solve_time_s"] += label.solve_time_s
        if not label.converged:
            stats["not_converged"] += 1
            fs = stats["failure_statuses"]
            fs[label.status] = fs.get(label.status, 0) + 1
            continue
        f = compute_features(layout, sit, report=stats["features"])
        check = float("nan")
        if check_every and j % check_every == 0:
            other = labeller.label(sit.mirrored())
            stats["solves"] += other.solves
            if other.converged:
                check = float(np.max(np.abs(mirror_label(label.wheels_mps) - other.wheels_mps)))
                stats["mirror_checked"] += 1
                stats["mirror_max_diff_mps"] = max(stats["mirror_max_diff_mps"], check)
                if check > MIRROR_TOLERANCE_MPS:
                    stats["mirror_over_tolerance"] += 1
                    # the two sides' multi-starts reached different optima: the cheaper one is
                    # the GPC's answer for both (the other side's starts missed it)
                    if other.cost < label.cost:
                        label = other.mirrored()
                        stats["mirror_check_replaced"] += 1
            else:
                stats["mirror_check_failed"] += 1
        sid = id_base + j
        builder.add(f, label.plan_wheels_mps, label, sid, False, check)
        if mirror and not builder.full:
            builder.add(mirror_features(layout, f), mirror_label(label.plan_wheels_mps), label, sid, True)
        j += 1


def label_shard(spec: DatasetSpec, index: int) -> tuple[int, dict, dict]:
    """Compute shard ``index`` of ``spec``: ``(index, arrays, stats)``. Deterministic."""
    t0, c0 = time.perf_counter(), time.process_time()
    labeller = _labeller(spec.config, spec.robot, spec.solver)
    n = spec.shard_samples(index)
    builder = _ShardBuilder(n, spec.layout.size, spec.config.horizon)
    stats = _new_stats()
    rng = np.random.default_rng([spec.seed, index])
    from .features import SituationTracker
    tracker = SituationTracker(spec.config)

    def stream():
        while True:
            yield sample_situation(rng, spec.config, spec.layout.name, spec.robot, spec.sampler, tracker)

    _label_situations(builder, stats, stream(), spec.layout, labeller, spec.mirror, spec.mirror_check_every,
                      index * _SHARD_STRIDE)
    stats["elapsed_s"] = time.perf_counter() - t0
    stats["cpu_s"] = time.process_time() - c0
    stats["worker_peak_rss_mb"] = _peak_rss_mb()
    return index, builder.arrays(), stats


# --------------------------------------------------------------------------------------
# files
# --------------------------------------------------------------------------------------
def shard_name(index: int, part: str = "") -> str:
    return f"shard-{index:05d}.npz" if not part else f"{part}-{index:05d}.npz"


def write_shard(path: Path, arrays: dict, spec_id: str, stats: dict) -> None:
    """Write ``arrays`` whole or not at all (temporary file, fsync, rename)."""
    with atomic_file(path, ".tmp") as tmp, open(tmp, "wb") as fh:
        np.savez(fh, spec_id=np.array(spec_id), stats_json=np.array(json.dumps(stats)), **arrays)


def read_shard(path, keys=None) -> dict:
    """The arrays of one shard (all, or ``keys``), plus ``spec_id`` and ``stats``."""
    with np.load(path, allow_pickle=False) as z:
        names = list(ARRAY_KEYS) if keys is None else list(keys)
        out = {k: z[k] for k in names}
        out["spec_id"] = str(z["spec_id"])
        out["stats"] = json.loads(str(z["stats_json"]))
    return out


def _shard_ok(path: Path, spec_id: str, n: int) -> bool:
    """A finished shard of this request: readable, right request, right size."""
    try:
        with np.load(path, allow_pickle=False) as z:
            return str(z["spec_id"]) == spec_id and len(z["labels"]) == n and z["features"].shape[0] == n
    except Exception:  # noqa: BLE001 - anything unreadable is simply not finished
        return False


def read_manifest(directory) -> dict:
    with open(Path(directory) / MANIFEST, encoding="utf-8") as fh:
        return json.load(fh)


def _write_json(path: Path, doc: dict) -> dict:
    """Write ``doc`` atomically; returns it as it reads back (tuples become lists)."""
    text = json.dumps(doc, indent=1, allow_nan=False, default=json_default) + "\n"
    with atomic_file(path, ".tmp") as tmp:  # .tmp: what a restart sweeps away
        tmp.write_text(text, encoding="utf-8")
    return json.loads(text)


@contextlib.contextmanager
def _locked(directory: Path):
    """One writer per directory (the lock dies with its process, kill -9 included)."""
    import fcntl
    fh = open(directory / LOCK, "a+")
    try:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise DatasetMismatch(f"{directory} is being written by another process") from None
        yield
    finally:
        fh.close()


def _remove_stale_temporaries(directory: Path) -> int:
    n = 0
    for p in directory.glob(".*.tmp"):
        with contextlib.suppress(FileNotFoundError):
            p.unlink()
            n += 1
    return n


def _peak_rss_mb() -> float:
    """Peak resident memory of this process so far, MB (Linux reports kB)."""
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _merge_stats(total: dict, s: dict) -> None:
    for k, v in s.items():
        if k in ("mirror_max_diff_mps", "worker_peak_rss_mb"):
            total[k] = max(total.get(k, 0.0), v)
        elif isinstance(v, dict):
            d = total.setdefault(k, {})
            for kk, vv in v.items():
                d[kk] = d.get(kk, 0) + vv
        else:
            total[k] = total.get(k, 0) + v


def _manifest(directory: Path, parts: dict, base: dict) -> dict:
    shards, samples = [], 0
    for part in parts.values():
        shards += part["shards"]
        samples += part["samples"]
    doc = dict(base)
    doc.update({"samples": samples, "shards": shards, "parts": parts})
    return doc


# --------------------------------------------------------------------------------------
# backends
# --------------------------------------------------------------------------------------
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


def run_tasks(fn, tasks: list, workers: int = 1, backend: str = "local", address: str | None = None):
    """``fn(*task)`` for every task on ``backend``, yielded as they finish (any order)."""
    if backend == "local":
        return _run_local(fn, tasks, workers)
    if backend == "ray":
        return _run_ray(fn, tasks, workers, address)
    raise ValueError(f"unknown backend {backend!r} (local or ray)")


# --------------------------------------------------------------------------------------
# the resumable writer
# --------------------------------------------------------------------------------------
def generate(out_dir, spec: DatasetSpec, workers: int = 1, backend: str = "local", address: str | None = None,
             progress=None, log=None) -> dict:
    """Label ``spec.samples`` samples into ``out_dir``, resuming whatever is finished there.

    ``progress``: an optional ``tqdm``-like factory ``progress(total=, initial=, unit=)``.
    ``log``: optional callable for one-line messages. Returns the manifest.
    Raises :class:`DatasetMismatch` if the directory holds another request's dataset.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with _locked(out):
        request, spec_id = spec.request(), spec.spec_id
        old = None
        if (out / MANIFEST).is_file():
            old = read_manifest(out)
            prev = old.get("parts", {}).get("offpolicy", {}).get("request")
            if prev is not None and prev != json.loads(json.dumps(request, default=str)):
                diff = sorted(k for k in set(prev) | set(request) if prev.get(k) != json.loads(
                    json.dumps(request.get(k), default=str)))
                raise DatasetMismatch(f"{out} holds a dataset made with other arguments ({', '.join(diff)} differ); "
                                      f"use another --out or the same arguments")
        stale = _remove_stale_temporaries(out)
        done, stats = {}, _new_stats()
        for i in range(spec.n_shards):
            path = out / shard_name(i)
            if path.exists() and _shard_ok(path, spec_id, spec.shard_samples(i)):
                done[i] = spec.shard_samples(i)
                _merge_stats(stats, read_shard(path, keys=())["stats"])
        todo = [i for i in range(spec.n_shards) if i not in done]
        parts = dict(old.get("parts", {})) if old else {}
        base = {
            "format": DATASET_FORMAT, "feature_names": list(spec.layout.feature_names),
            "label_names": list(LABEL_NAMES), "feature_layout": spec.layout.to_dict(), "preset": spec.config.name,
            "planner_config": spec.config.to_dict(), "robot": spec.robot.to_dict(), "seed": spec.seed,
            "solver": spec.solver, "samples_requested": spec.samples, "arrays": list(ARRAY_KEYS),
            "guess_names": list(GUESS_NAMES),
        }

        def record(complete: bool, run: dict) -> dict:
            names = [shard_name(i) for i in sorted(done)]
            parts["offpolicy"] = {
                "kind": "sampled situations", "request": request, "spec_id": spec_id, "samples": sum(done.values()),
                "samples_requested": spec.samples, "shards": names, "shards_total": spec.n_shards,
                "complete": complete, "stats": _stats_summary(stats), "last_run": run,
            }
            doc = _manifest(out, parts, base)
            doc["complete"] = all(p.get("complete", False) for p in parts.values())
            return _write_json(out / MANIFEST, doc)

        run = {"backend": backend, "workers": workers, "resumed_shards": len(done), "stale_temporaries_removed": stale,
               "shards_done": 0, "samples_done": 0, "elapsed_s": 0.0, "samples_per_s": None}
        manifest = record(not todo, run)
        if log and done:
            log(f"resuming: {len(done)} of {spec.n_shards} shards already finished")
        if not todo:
            return manifest
        t0 = time.perf_counter()
        results = run_tasks(label_shard, [(spec, i) for i in todo], workers, backend, address)
        bar = progress(total=spec.samples, initial=sum(done.values()), unit="sample") if progress else None
        try:
            for index, arrays, st in results:
                write_shard(out / shard_name(index), arrays, spec_id, st)
                n = len(arrays["labels"])
                done[index] = n
                _merge_stats(stats, st)
                run["shards_done"] += 1
                run["samples_done"] += n
                run["elapsed_s"] = time.perf_counter() - t0
                run["samples_per_s"] = run["samples_done"] / max(run["elapsed_s"], 1e-9)
                # CPU seconds the workers spent: on a busy machine, samples per worker CPU
                # second times the number of free cores is what the machine alone would do
                run["worker_cpu_s"] = run.get("worker_cpu_s", 0.0) + st.get("cpu_s", 0.0)
                run["samples_per_worker_cpu_s"] = run["samples_done"] / max(run["worker_cpu_s"], 1e-9)
                run["parent_peak_rss_mb"] = _peak_rss_mb()
                run["worker_peak_rss_mb"] = max(run.get("worker_peak_rss_mb", 0.0), st.get("worker_peak_rss_mb", 0.0))
                manifest = record(len(done) == spec.n_shards, run)
                if bar is not None:
                    bar.update(n)
                    bar.set_postfix_str(f"{run['samples_per_s']:.0f} samples/s", refresh=False)
        finally:
            if bar is not None:
                bar.close()
        return manifest


def _stats_summary(stats: dict) -> dict:
    s = dict(stats)
    s["mirror_tolerance_mps"] = MIRROR_TOLERANCE_MPS
    s["solve_time_s"] = float(s.get("solve_time_s", 0.0))
    return s


# --------------------------------------------------------------------------------------
# reading
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class LoadedDataset:
    X: np.ndarray
    """(n, F) features."""
    Y: np.ndarray
    """(n, 2) labels: right, left wheel speed, m/s."""
    groups: np.ndarray
    """(n,) situation ids: a sample and its mirror share one (keep them on one side of a split)."""
    layout: FeatureLayout
    manifest: dict


def load_dataset(directory, parts: tuple[str, ...] | None = None) -> LoadedDataset:
    """All finished samples of a dataset directory (every part, or ``parts``)."""
    directory = Path(directory)
    man = read_manifest(directory)
    layout = layout_from_dict(man["feature_layout"])
    X, Y, G = [], [], []
    for name, part in man.get("parts", {}).items():
        if parts is not None and name not in parts:
            continue
        for shard in part["shards"]:
            a = read_shard(directory / shard, keys=("features", "labels", "situation_id"))
            X.append(a["features"])
            Y.append(a["labels"])
            G.append(a["situation_id"])
    if not X:
        raise ValueError(f"{directory}: no finished samples")
    return LoadedDataset(np.concatenate(X), np.concatenate(Y), np.concatenate(G), layout, man)


# --------------------------------------------------------------------------------------
# on-policy data (DAgger)
# --------------------------------------------------------------------------------------
class _Recorder:
    """Wraps a policy: passes decisions through and records the situation at every sample,
    built by the same :class:`SituationTracker` the deployed policy uses.

    With ``noise_mps`` > 0 the wheel speeds the policy asks for are perturbed by independent
    N(0, noise_mps) before they are applied (DART, Laskey et al. 2017): the expert drives,
    but the recorded states spread around its path the way a learner's errors spread them.
    The labels are not affected: every recorded situation is labelled afresh by the GPC.
    The number of perturbed decisions is counted (``counters["driving_noise_applied"]``)."""

    def __init__(self, policy, config: PlannerConfig, noise_mps: float = 0.0, seed: int = 0):
        from .features import SituationTracker
        self.policy = policy
        self.tracker = SituationTracker(config)
        self.sample_time_s = policy.sample_time_s
        self.situations = []
        self.noise_mps = float(noise_mps)
        self._rng = np.random.default_rng(seed)
        self._perturbed = 0

    @property
    def counters(self):
        c = dict(getattr(self.policy, "counters", {}))
        if self.noise_mps > 0:
            c["driving_noise_applied"] = self._perturbed
        return c

    def reset(self) -> None:
        self.policy.reset()
        self.tracker.reset()
        self.situations = []
        self._perturbed = 0

    def decide(self, obs):
        self.situations.append(self.tracker.update(obs))
        dec = self.policy.decide(obs)
        if self.noise_mps > 0:
            e = self._rng.normal(0.0, self.noise_mps, 2)
            dec = replace(dec, v_right_mps=float(dec.v_right_mps + e[0]), v_left_mps=float(dec.v_left_mps + e[1]))
            self._perturbed += 1
        return dec


def perturb_start(scenario, rng: np.random.Generator, lateral_m: float, heading_rad: float):
    """``scenario`` with the robot's start moved sideways by U(-lateral_m, lateral_m) from the
    path and turned by U(-heading_rad, heading_rad) (recovering starts, as in Fig. 7.3)."""
    if lateral_m <= 0 and heading_rad <= 0:
        return scenario
    from casadi_gpc.robot import RobotState
    s0 = scenario.robot_start
    off = rng.uniform(-lateral_m, lateral_m)
    dh = rng.uniform(-heading_rad, heading_rad)
    start = RobotState(s0.x_m - off * math.sin(s0.heading_rad), s0.y_m + off * math.cos(s0.heading_rad),
                       s0.heading_rad + dh)
    return replace(scenario, robot_start=start)


def collect_on_policy(policy, scenarios, config: PlannerConfig, layout: FeatureLayout,
                      labeller: Labeller | None = None, mirror: bool = True, id_base: int = 0,
                      mirror_check_every: int = 0, noise_mps: float = 0.0, noise_seed: int = 0) -> tuple[dict, dict]:
    """DAgger: run ``policy`` (anything with ``decide(observation)``) on every scenario,
    label every situation it visits with the GPC, and return ``(arrays, stats)`` in the
    shard format (``stats["episodes"]`` lists each episode's outcome). ``noise_mps``
    perturbs the applied wheel speeds (see :class:`_Recorder`)."""
    from casadi_gpc.simulator import simulate
    if abs(policy.sample_time_s - config.sample_time_s) > 1e-12:
        raise ValueError(f"policy sample time {policy.sample_time_s} s != planner's {config.sample_time_s} s")
    labeller = labeller or Labeller(config)
    recorder = _Recorder(policy, config, noise_mps, noise_seed)
    situations, episodes = [], []
    for sc in scenarios:
        log = simulate(sc, recorder, "on-policy")
        situations += recorder.situations
        episodes.append({"scenario": sc.name, "outcome": log.outcome, "steps": len(log.decisions),
                         "min_clearance_m": float(log.min_clearance_m),
                         "noise_applied": int(log.events.get("driving_noise_applied", 0))})
    n = len(situations) * (2 if mirror else 1)
    builder = _ShardBuilder(n, layout.size, config.horizon)
    stats = _new_stats()
    _label_situations(builder, stats, iter(situations), layout, labeller, mirror, mirror_check_every, id_base)
    arrays = {k: (v[: builder.k] if isinstance(v, np.ndarray) else v) for k, v in builder.arrays().items()}
    stats["episodes"] = episodes
    return arrays, stats


def _on_policy_chunk(policy_factory, scenarios, config: PlannerConfig, layout: FeatureLayout, solver: str,
                     robot: RobotParams, mirror: bool, mirror_check_every: int, id_base: int, chunk: int,
                     noise_mps: float = 0.0):
    """Worker task: one chunk of DAgger episodes (policy and labeller built once per process)."""
    key = ("policy", repr(policy_factory))
    if key not in _LABELLERS:
        _LABELLERS[key] = policy_factory()
    arrays, stats = collect_on_policy(_LABELLERS[key], scenarios, config, layout, _labeller(config, robot, solver),
                                      mirror, id_base + chunk * _SHARD_STRIDE, mirror_check_every,
                                      noise_mps, noise_seed=id_base + chunk)
    return chunk, arrays, stats


def collect_on_policy_parallel(policy_factory, scenarios, config: PlannerConfig, layout: FeatureLayout,
                               solver: str, robot: RobotParams | None = None, workers: int = 1,
                               backend: str = "local", address: str | None = None, mirror: bool = True,
                               id_base: int = 0, mirror_check_every: int = 0, progress=None,
                               noise_mps: float = 0.0) -> tuple[dict, dict]:
    """:func:`collect_on_policy` over worker processes (or Ray). ``policy_factory`` is a
    picklable callable returning the policy (e.g. ``functools.partial(OnnxPolicy, path)``).
    Returns the arrays of all chunks, in episode order, and the merged stats."""
    robot = robot or RobotParams()
    scenarios = list(scenarios)
    size = max(1, -(-len(scenarios) // max(1, 4 * workers)))
    chunks = [scenarios[i:i + size] for i in range(0, len(scenarios), size)]
    if len(chunks) > _SHARD_STRIDE // 1000:
        raise ValueError(f"too many chunks ({len(chunks)}); use fewer episodes per round")
    tasks = [(policy_factory, c, config, layout, solver, robot, mirror, mirror_check_every, id_base, i, noise_mps)
             for i, c in enumerate(chunks)]
    results = {}
    pending = run_tasks(_on_policy_chunk, tasks, workers, backend, address)
    bar = progress(total=len(scenarios), unit="ep") if progress else None
    try:
        for i, arrays, stats in pending:
            results[i] = (arrays, stats)
            if bar is not None:
                bar.update(len(chunks[i]))
    finally:
        if bar is not None:
            bar.close()
    ordered = [results[i] for i in range(len(chunks))]
    arrays = {k: np.concatenate([a[k] for a, _ in ordered]) for k in ordered[0][0]}
    stats, episodes = _new_stats(), []
    for _, st in ordered:
        episodes += st["episodes"]
        _merge_stats(stats, {k: v for k, v in st.items() if k != "episodes"})
    stats["episodes"] = episodes
    return arrays, stats


def append_part(out_dir, part: str, arrays: dict, stats: dict, info: dict | None = None) -> dict:
    """Add ``arrays`` (shard format) to a dataset as part ``part`` (e.g. ``dagger1``), written
    whole or not at all; the manifest's ``samples`` grows by their number."""
    out = Path(out_dir)
    if not part.replace("_", "").isalnum() or part == "offpolicy" or part.startswith("shard"):
        raise ValueError(f"bad part name {part!r}")
    with _locked(out):
        man = read_manifest(out)
        if part in man.get("parts", {}):
            raise DatasetMismatch(f"{out} already has a part {part!r}")
        lay = layout_from_dict(man["feature_layout"])
        if arrays["features"].shape[1:] != (lay.size,):
            raise ValueError(f"features have {arrays['features'].shape[1:]} columns, the dataset {lay.size}")
        name = shard_name(0, part)
        stats = {k: v for k, v in stats.items() if k != "episodes"} | {"episodes": stats.get("episodes", [])}
        write_shard(out / name, arrays, _digest(info or {}), stats)
        parts = dict(man["parts"])
        parts[part] = {"kind": "on-policy (DAgger)", "samples": int(len(arrays["labels"])), "shards": [name],
                       "complete": True, "info": info or {}, "stats": _stats_summary(
                           {k: v for k, v in stats.items() if k != "episodes"}),
                       "episodes": len(stats.get("episodes", []))}
        base = {k: v for k, v in man.items() if k not in ("samples", "shards", "parts")}
        doc = _manifest(out, parts, base)
        doc["complete"] = all(p.get("complete", False) for p in parts.values())
        return _write_json(out / MANIFEST, doc)
