"""``--backend ray`` for real, on a local Ray instance with two workers: the same shards as
the local backend, bit for bit, and resuming works the same way."""
from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

ray = pytest.importorskip("ray")

from casadi_gpc.config import preset  # noqa: E402
from nn_export.training.dataset import ARRAY_KEYS, DatasetSpec, generate, read_manifest, read_shard  # noqa: E402
from nn_export.runtime.layouts import layout_for  # noqa: E402
from nn_export.training.labels import Labeller  # noqa: E402

PAPER = preset("paper")


def _spec():
    return DatasetSpec(samples=80, config=PAPER, layout=layout_for("paper", PAPER.horizon), seed=5, shard_size=20,
                       mirror_check_every=0, solver=Labeller(PAPER).solver)


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def test_ray_backend_writes_the_same_shards_as_local_workers(tmp_path, local_ray):
    local, remote = tmp_path / "local", tmp_path / "ray"
    generate(local, _spec(), workers=1, backend="local")
    man = generate(remote, _spec(), workers=2, backend="ray")
    assert man["samples"] == 80 and man["complete"]
    assert man["parts"]["offpolicy"]["last_run"]["backend"] == "ray"
    for s in read_manifest(local)["shards"]:
        a, b = read_shard(local / s), read_shard(remote / s)
        for k in ARRAY_KEYS:
            np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    # resume on Ray: a lost shard is redone, the others are not
    (remote / "shard-00002.npz").unlink()
    man = generate(remote, _spec(), workers=2, backend="ray")
    run = man["parts"]["offpolicy"]["last_run"]
    assert run["resumed_shards"] == 3 and run["shards_done"] == 1 and man["samples"] == 80
    np.testing.assert_array_equal(read_shard(remote / "shard-00002.npz")["features"],
                                  read_shard(local / "shard-00002.npz")["features"])


def _cli(out, *extra):
    return subprocess.run([sys.executable, "-m", "gpcnav", "dataset", "--out", str(out), "--samples", "40",
                           "--shard-size", "20", "--preset", "paper", "--backend", "ray", "--workers", "2",
                           "--mirror-check-every", "0", *extra], capture_output=True, text=True, timeout=300)


def test_cli_ray_backend_on_an_existing_cluster(tmp_path, local_ray):
    out = tmp_path / "ds"
    proc = _cli(out, "--address", ray.get_runtime_context().gcs_address)
    assert proc.returncode == 0, proc.stderr[-2000:]
    man = read_manifest(out)
    assert man["samples"] == 40 and man["parts"]["offpolicy"]["last_run"]["backend"] == "ray"
    assert "samples/s" in proc.stdout


@pytest.mark.slow
def test_cli_ray_backend_starts_its_own_local_instance(tmp_path):
    out = tmp_path / "ds"
    proc = _cli(out)
    assert proc.returncode == 0, proc.stderr[-2000:]
    man = read_manifest(out)
    assert man["samples"] == 40 and man["parts"]["offpolicy"]["last_run"]["backend"] == "ray"
    assert "samples/s" in proc.stdout
