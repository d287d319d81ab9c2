"""Labelled datasets on disk (see :mod:`nn_export.training.dataset.shards` for the files).

Rooms: ``spec`` (:class:`DatasetSpec`, what decides the contents), ``shards`` (the shard
files, the manifest, the directory lock, reading back), ``labelling`` (situations into shard
arrays, one labeller per worker), ``writer`` (:func:`generate`, resumable) and
``onpolicy`` (DAgger/DART rounds appended as parts). Work runs on the one worker pool,
:class:`casadi_gpc.pool.WorkerPool` (local processes or Ray).
"""
from .labelling import label_shard, prepare_labeller
from .onpolicy import OnPolicyOptions, append_part, collect_on_policy, collect_on_policy_parallel, perturb_start
from .shards import LoadedDataset, load_dataset, read_manifest, read_shard
from .spec import ARRAY_KEYS, DATASET_FORMAT, PART_STRIDE, DatasetMismatch, DatasetSpec
from .writer import generate

__all__ = [
    "DATASET_FORMAT", "DatasetSpec", "DatasetMismatch", "label_shard", "generate", "read_manifest", "read_shard",
    "load_dataset", "LoadedDataset", "collect_on_policy", "collect_on_policy_parallel", "append_part", "ARRAY_KEYS",
    "prepare_labeller", "OnPolicyOptions", "perturb_start", "PART_STRIDE",
]
