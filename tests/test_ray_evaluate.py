"""``--backend ray`` on ``evaluate`` and ``compare``: the same EVAL outcomes as local worker
processes, on a local Ray instance with two workers."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

ray = pytest.importorskip("ray")

from conftest import REPO  # noqa: E402

TIMING = {"compute_median_s"}  # the only field of an episode that may differ between runs


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield ray.get_runtime_context().gcs_address
    ray.shutdown()


def _cli(cwd, *args):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    r = subprocess.run([sys.executable, "-m", "gpcnav", *map(str, args)], capture_output=True, text=True, timeout=600,
                       cwd=cwd, env=env)
    assert r.returncode == 0, r.stderr[-2000:]
    return r


def _episodes(doc):
    return [{k: v for k, v in e.items() if k not in TIMING} for e in doc["episodes_detail"]]


@pytest.mark.slow  # 12 s: kept out of the default suite (CI: under 10 minutes); Ray's pool runs in test_ray_backend
def test_evaluate_and_compare_on_ray_give_the_local_outcomes(tmp_path, local_ray):
    suite = ["--suite", "circle-crossing", "--count", "3", "--seed", "1", "--movers", "4"]
    _cli(tmp_path, "evaluate", *suite, "--controller", "orca", "--workers", "2", "--out", tmp_path / "local.json")
    _cli(tmp_path, "evaluate", *suite, "--controller", "orca", "--workers", "2", "--backend", "ray", "--address",
         local_ray, "--out", tmp_path / "ray.json")
    local, remote = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("local", "ray"))
    assert remote["backend"] == "ray" and local["backend"] == "local"
    assert _episodes(remote) == _episodes(local)
    for key in ("success_rate", "collision_rate", "timeout_rate", "min_clearance_m", "time_to_goal_s", "danger_rate"):
        assert remote[key] == local[key], key
    # compare runs its episodes on the same pool
    _cli(tmp_path, "compare", *suite, "--controllers", "orca,hrvo", "--workers", "2", "--backend", "ray",
         "--address", local_ray, "--out", tmp_path / "cmp.json")
    cmp = json.loads((tmp_path / "cmp.json").read_text())
    assert _episodes(cmp["controllers"][0]) == _episodes(local)


def test_address_without_ray_backend_is_refused(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    r = subprocess.run([sys.executable, "-m", "gpcnav", "evaluate", "--suite", "random", "--count", "1",
                        "--controller", "orca", "--address", "127.0.0.1:6379"], capture_output=True, text=True,
                       timeout=120, cwd=tmp_path, env=env)
    assert r.returncode == 2 and "--address needs --backend ray" in r.stderr


@pytest.mark.slow  # about 20 s: the default suite stays under 10 minutes on two cores
def test_evaluate_on_ray_killed_partway_resumes_to_the_uninterrupted_document(tmp_path, local_ray):
    """The finished episodes are kept by the driver as they come back from the cluster: a
    driver killed with kill -9 and started again reuses them, on Ray as on local workers."""
    from test_resume import NO_CLOCK, _kill_partway, _reused_line, _same_document
    argv = ["evaluate", "--suite", "circle-crossing", "--movers", "10", "--count", "8", "--workers", "2",
            "--backend", "ray", "--address", local_ray, *NO_CLOCK]
    _cli(tmp_path, *argv, "--out", "W.json")
    kept = _kill_partway(tmp_path, tmp_path / "E.json.episodes", [*argv, "--out", "E.json"], 3)
    n_kept = sum(len(v) for v in kept.values())
    assert 3 <= n_kept < 8
    again = _cli(tmp_path, *argv, "--out", "E.json")
    assert _reused_line(again.stderr, "evaluate") == n_kept
    resumed, whole = (json.loads((tmp_path / f"{n}.json").read_text()) for n in ("E", "W"))
    _same_document(resumed, whole, kept)
    assert resumed["backend"] == "ray"
