"""A dataset's files: shards, the manifest, the directory lock, and reading them back.

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
``decision_pass``      (n,)          0: the planner's own situation (real reference,
                                     obstacles); 1, 2: the paper's first (no obstacle)
                                     or second pass (the predicted path as reference);
                                     absent from shards written before it existed
=====================  ============  ==================================================

plus ``spec_id`` (which request made it) and ``stats_json`` (the shard's counters).
"""
from __future__ import annotations

import contextlib
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casadi_gpc.io import UNREADABLE_NPZ, atomic_file, json_default

from ...runtime.layouts import FeatureLayout, layout_from_dict
from .spec import ARRAY_KEYS, MIRROR_TOLERANCE_MPS, DatasetMismatch

__all__ = ["MANIFEST", "LOCK", "shard_name", "write_shard", "read_shard", "shard_ok", "read_manifest", "write_manifest",
           "locked", "remove_stale_temporaries", "merge_stats", "manifest_document", "stats_summary", "LoadedDataset",
           "load_dataset", "TARGETS"]

MANIFEST = "manifest.json"
LOCK = ".lock"


def shard_name(index: int, part: str = "") -> str:
    return f"shard-{index:05d}.npz" if not part else f"{part}-{index:05d}.npz"


def write_shard(path: Path, arrays: dict, spec_id: str, stats: dict) -> None:
    """Write ``arrays`` whole or not at all (temporary file, fsync, rename)."""
    with atomic_file(path, ".tmp") as tmp, open(tmp, "wb") as fh:
        np.savez(fh, spec_id=np.array(spec_id), stats_json=np.array(json.dumps(stats)), **arrays)


def read_shard(path, keys=None) -> dict:
    """The arrays of one shard (all, or ``keys``), plus ``spec_id`` and ``stats``. A shard
    that is not a readable archive (damaged on disk, cut short in a copy) is a ``ValueError``
    naming it (and, for an off-policy shard, that the dataset's own command redoes it, tested):
    zipfile's ``BadZipFile``, ``EOFError`` or zlib's error were a traceback in ``gpcnav train``."""
    try:
        with np.load(path, allow_pickle=False) as z:
            # all: every key this code writes that the shard has (older shards lack decision_pass)
            names = [k for k in ARRAY_KEYS if k in z.files] if keys is None else list(keys)
            out = {k: z[k] for k in names}
            out["spec_id"] = str(z["spec_id"])
            out["stats"] = json.loads(str(z["stats_json"]))
    except UNREADABLE_NPZ as exc:
        name = Path(path).name
        redo = "; `gpcnav dataset` with the same arguments redoes a damaged shard" if name.startswith("shard-") else ""
        raise ValueError(f"{name}: not a readable shard ({exc or type(exc).__name__}){redo}") from None
    return out


def shard_ok(path: Path, spec_id: str, n: int) -> bool:
    """A finished shard of this request: readable, right request, right size."""
    try:
        with np.load(path, allow_pickle=False) as z:
            return str(z["spec_id"]) == spec_id and len(z["labels"]) == n and z["features"].shape[0] == n
    except Exception:  # noqa: BLE001 - anything unreadable is simply not finished
        return False


def read_manifest(directory) -> dict:
    with open(Path(directory) / MANIFEST, encoding="utf-8") as fh:
        return json.load(fh)


def write_manifest(path: Path, doc: dict) -> dict:
    """Write ``doc`` atomically; returns it as it reads back (tuples become lists)."""
    text = json.dumps(doc, indent=1, allow_nan=False, default=json_default) + "\n"
    with atomic_file(path, ".tmp") as tmp:  # .tmp: what a restart sweeps away
        tmp.write_text(text, encoding="utf-8")
    return json.loads(text)


@contextlib.contextmanager
def locked(directory: Path):
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




def remove_stale_temporaries(directory: Path) -> int:
    n = 0
    for p in directory.glob(".*.tmp"):
        with contextlib.suppress(FileNotFoundError):
            p.unlink()
            n += 1
    return n



def merge_stats(total: dict, s: dict) -> None:
    for k, v in s.items():
        if k in ("mirror_max_diff_mps", "worker_peak_rss_mb"):
            total[k] = max(total.get(k, 0.0), v)
        elif isinstance(v, dict):
            d = total.setdefault(k, {})
            for kk, vv in v.items():
                d[kk] = d.get(kk, 0) + vv
        else:
            total[k] = total.get(k, 0) + v


def manifest_document(directory: Path, parts: dict, base: dict) -> dict:
    shards, samples = [], 0
    for part in parts.values():
        shards += part["shards"]
        samples += part["samples"]
    doc = dict(base)
    doc.update({"samples": samples, "shards": shards, "parts": parts})
    return doc



def stats_summary(stats: dict) -> dict:
    s = dict(stats)
    s["mirror_tolerance_mps"] = MIRROR_TOLERANCE_MPS
    s["solve_time_s"] = float(s.get("solve_time_s", 0.0))
    return s



@dataclass(frozen=True)
class LoadedDataset:
    X: np.ndarray
    """(n, F) features."""
    Y: np.ndarray
    """(n, 2) labels: right, left wheel speed, m/s; with ``target="plan"``, (n, 2 H): the whole
    planned sequence, right then left wheel of each step."""
    groups: np.ndarray
    """(n,) situation ids: a sample and its mirror share one (keep them on one side of a split)."""
    layout: FeatureLayout
    manifest: dict
    cost: np.ndarray | None = None
    """(n,) the chosen plan's cost."""
    candidate_costs: np.ndarray | None = None
    """(n, G) each initial guess's converged cost (NaN where it failed; manifest ``guess_names``)."""


TARGETS = {"command": "labels", "plan": "plan_wheels_mps"}
"""What a network learns (``load_dataset``'s ``target``): the first command, or the whole plan."""


def load_dataset(directory, parts: tuple[str, ...] | None = None, target: str = "command") -> LoadedDataset:
    """All finished samples of a dataset directory (every part, or ``parts``); ``Y`` holds
    the :data:`TARGETS` entry ``target``."""
    if target not in TARGETS:
        raise ValueError(f"target must be one of {', '.join(TARGETS)}, got {target!r}")
    key = TARGETS[target]
    directory = Path(directory)
    man = read_manifest(directory)
    layout = layout_from_dict(man["feature_layout"])
    X, Y, G, C, CC = [], [], [], [], []
    for name, part in man.get("parts", {}).items():
        if parts is not None and name not in parts:
            continue
        for shard in part["shards"]:
            a = read_shard(directory / shard, keys=("features", key, "situation_id", "cost", "candidate_costs"))
            X.append(a["features"])
            Y.append(a[key].reshape(len(a[key]), -1))
            G.append(a["situation_id"])
            C.append(a["cost"])
            CC.append(a["candidate_costs"])
    if not X:
        raise ValueError(f"{directory}: no finished samples")
    return LoadedDataset(np.concatenate(X), np.concatenate(Y), np.concatenate(G), layout, man, np.concatenate(C),
                         np.concatenate(CC))
