"""The resumable writer: label a spec's shards into a directory on a worker pool, resuming
whatever is finished there (the parent process writes every file; see
:mod:`nn_export.training.dataset.shards`).

A damaged ``manifest.json`` (not JSON, or not a manifest) loses nothing: every finished
shard carries the ``spec_id`` of the request that made it, so the off-policy part is found
again by the same scan a resume does, the on-policy parts from their own shards, and the
manifest is written anew. No shard is relabelled.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

from casadi_gpc.pool import WorkerPool

from ..labels import GUESS_NAMES, LABEL_NAMES
from .labelling import label_shard, new_stats, peak_rss_mb
from .shards import (MANIFEST, locked, manifest_document, merge_stats, read_manifest, read_shard,
                     remove_stale_temporaries, shard_name, shard_ok, stats_summary, write_manifest, write_shard)
from .spec import ARRAY_KEYS, DATASET_FORMAT, DatasetMismatch, DatasetSpec

__all__ = ["generate"]


def generate(out_dir, spec: DatasetSpec, workers: int = 1, backend: str = "local", address: str | None = None,
             progress=None, log=None) -> dict:
    """Label ``spec.samples`` samples into ``out_dir``, resuming whatever is finished there.

    ``workers``, ``backend``, ``address``: the :class:`~casadi_gpc.pool.WorkerPool`.
    ``progress``: an optional ``tqdm``-like factory ``progress(total=, initial=, unit=)``.
    ``log``: optional callable for one-line messages. Returns the manifest.
    Raises :class:`DatasetMismatch` if the directory holds another request's dataset.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with locked(out):
        parts = _previous_parts(out, spec, log)
        stale = remove_stale_temporaries(out)
        done, stats = _finished_shards(out, spec)
        todo = [i for i in range(spec.n_shards) if i not in done]
        run = {"backend": backend, "workers": workers, "resumed_shards": len(done), "stale_temporaries_removed": stale,
               "shards_done": 0, "samples_done": 0, "elapsed_s": 0.0, "samples_per_s": None}
        record = _ManifestWriter(out, spec, parts, done, stats)
        manifest = record(not todo, run)
        if log and done:
            log(f"resuming: {len(done)} of {spec.n_shards} shards already finished")
        if not todo:
            return manifest
        return _label_missing(out, spec, todo, WorkerPool(workers, backend, address), record, run, progress) or manifest


def _previous_parts(out: Path, spec: DatasetSpec, log) -> dict:
    """The parts of the manifest already in ``out`` (none for a new directory), after
    checking that its off-policy part was made by the same request; a damaged manifest's
    on-policy parts are rebuilt from their shards."""
    if not (out / MANIFEST).is_file():
        return {}
    try:
        old = read_manifest(out)
        parts = old["parts"]
        if not isinstance(parts, dict):
            raise TypeError("parts is not a table")
    except (ValueError, KeyError, TypeError, OSError) as exc:
        _refuse_foreign_shards(out, spec)
        parts = _parts_from_shards(out)
        if log:
            log(f"{MANIFEST} was damaged ({type(exc).__name__}): rebuilt from the shards, finished shards reused")
        return parts
    request = json.loads(json.dumps(spec.request(), default=str))
    prev = parts.get("offpolicy", {}).get("request")
    if prev is not None and prev != request:
        diff = sorted(k for k in set(prev) | set(request) if prev.get(k) != request.get(k))
        verb = "differ" if len(diff) > 1 else "differs"
        raise DatasetMismatch(f"{out} holds a dataset made with other arguments ({', '.join(diff)} {verb}); "
                              f"use another --out or the same arguments")
    return dict(parts)


def _refuse_foreign_shards(out: Path, spec: DatasetSpec) -> None:
    """With the manifest lost, the shards say which request made them: refuse to write over
    another request's shards (a resume with other arguments)."""
    for path in sorted(out.glob("shard-*.npz")):
        try:
            spec_id = read_shard(path, keys=())["spec_id"]
        except Exception:  # noqa: BLE001 - an unreadable shard is simply not finished
            continue
        if spec_id != spec.spec_id:
            raise DatasetMismatch(f"{out}: {MANIFEST} is damaged and {path.name} was made with other arguments; "
                                  f"use another --out or the arguments that made it")


def _parts_from_shards(out: Path) -> dict:
    """The on-policy parts of ``out`` from their shard files (``<part>-00000.npz``), oldest
    first, as :func:`~nn_export.training.dataset.onpolicy.append_part` recorded them but for
    the round's description, which only the lost manifest held. The off-policy part is
    found by :func:`_finished_shards` and placed first, where it always is."""
    parts = {"offpolicy": None}
    files = sorted((p for p in out.glob("*-00000.npz") if not p.name.startswith("shard-")),
                   key=lambda p: p.stat().st_mtime)
    for path in files:
        a = read_shard(path, keys=("labels",))
        stats = a["stats"]
        parts[path.name[: -len("-00000.npz")]] = {
            "kind": "on-policy (DAgger)", "samples": int(len(a["labels"])), "shards": [path.name], "complete": True,
            "info": {"recovered": f"{MANIFEST} was damaged; the round's description was lost with it"},
            "stats": stats_summary({k: v for k, v in stats.items() if k != "episodes"}),
            "episodes": len(stats.get("episodes", []))}
    return parts


def _finished_shards(out: Path, spec: DatasetSpec) -> tuple[dict[int, int], dict]:
    """The shards of ``spec`` already on disk (index -> samples) and their merged stats."""
    done, stats = {}, new_stats()
    for i in range(spec.n_shards):
        path = out / shard_name(i)
        if path.exists() and shard_ok(path, spec.spec_id, spec.shard_samples(i)):
            done[i] = spec.shard_samples(i)
            merge_stats(stats, read_shard(path, keys=())["stats"])
    return done, stats


class _ManifestWriter:
    """Writes the manifest: the other parts as found, the off-policy part as it stands."""

    def __init__(self, out: Path, spec: DatasetSpec, parts: dict, done: dict, stats: dict):
        self.out, self.spec, self.parts, self.done, self.stats = out, spec, parts, done, stats
        self.base = {
            "format": DATASET_FORMAT, "feature_names": list(spec.layout.feature_names),
            "label_names": list(LABEL_NAMES), "feature_layout": spec.layout.to_dict(), "preset": spec.config.name,
            "planner_config": spec.config.to_dict(), "robot": spec.robot.to_dict(), "seed": spec.seed,
            "solver": spec.solver, "samples_requested": spec.samples, "arrays": list(ARRAY_KEYS),
            "guess_names": list(GUESS_NAMES),
        }

    def __call__(self, complete: bool, run: dict) -> dict:
        spec, done = self.spec, self.done
        self.parts["offpolicy"] = {
            "kind": "sampled situations", "request": spec.request(), "spec_id": spec.spec_id,
            "samples": sum(done.values()), "samples_requested": spec.samples,
            "shards": [shard_name(i) for i in sorted(done)], "shards_total": spec.n_shards,
            "complete": complete, "stats": stats_summary(self.stats), "last_run": run,
        }
        doc = manifest_document(self.out, self.parts, self.base)
        doc["complete"] = all(p.get("complete", False) for p in self.parts.values())
        return write_manifest(self.out / MANIFEST, doc)


def _label_missing(out: Path, spec: DatasetSpec, todo: list[int], pool: WorkerPool, record: _ManifestWriter, run: dict,
                   progress) -> dict | None:
    """Label the shards ``todo`` on ``pool``, writing each (and the manifest) as it comes."""
    manifest = None
    t0 = time.perf_counter()
    results = pool.imap_unordered(label_shard, [(spec, i) for i in todo])
    done = record.done
    bar = progress(total=spec.samples, initial=sum(done.values()), unit="sample") if progress else None
    try:
        for index, arrays, st in results:
            write_shard(out / shard_name(index), arrays, spec.spec_id, st)
            n = len(arrays["labels"])
            done[index] = n
            merge_stats(record.stats, st)
            _account(run, n, st, t0)
            manifest = record(len(done) == spec.n_shards, run)
            if bar is not None:
                bar.update(n)
                bar.set_postfix_str(f"{run['samples_per_s']:.0f} samples/s", refresh=False)
    finally:
        if bar is not None:
            bar.close()
    return manifest


def _account(run: dict, n: int, st: dict, t0: float) -> None:
    """This run's counts and rates after a shard of ``n`` samples with stats ``st``."""
    run["shards_done"] += 1
    run["samples_done"] += n
    run["elapsed_s"] = time.perf_counter() - t0
    run["samples_per_s"] = run["samples_done"] / max(run["elapsed_s"], 1e-9)
    # CPU seconds the workers spent: on a busy machine, samples per worker CPU
    # second times the number of free cores is what the machine alone would do
    run["worker_cpu_s"] = run.get("worker_cpu_s", 0.0) + st.get("cpu_s", 0.0)
    run["samples_per_worker_cpu_s"] = run["samples_done"] / max(run["worker_cpu_s"], 1e-9)
    run["parent_peak_rss_mb"] = peak_rss_mb()
    run["worker_peak_rss_mb"] = max(run.get("worker_peak_rss_mb", 0.0), st.get("worker_peak_rss_mb", 0.0))
