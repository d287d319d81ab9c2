"""Solve lanes fitted to the worker pool (``gpcnav.commands.common.for_pool``): a run's
workers and their planners' threads never ask for more cores than there are, and the
documents say what ran (``workers``, ``solve_lanes``)."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from casadi_gpc.config import preset
from casadi_gpc.pool import WorkerPool
from gpcnav.commands import common
from gpcnav.commands.common import for_pool, planner_changes

IMPROVED = preset("improved")


@pytest.mark.parametrize("cores, workers, backend, lanes", [
    (2, 2, "local", 1),    # the 2-core machine, two workers: one lane each, not two threads each on one core
    (2, 1, "local", 2),    # one worker: the preset's two
    (1, 1, "local", 1),    # one core: one lane
    (4, 2, "local", 2),
    (16, 3, "local", 2),   # five cores a worker: the preset's two are the most
    (3, 2, "local", 1),
    (2, 8, "local", 1),    # more workers than cores: still one lane, never none
    (64, 4, "ray", 1),     # a Ray task holds one CPU
])
def test_lanes_are_the_cores_each_worker_is_left(monkeypatch, cores, workers, backend, lanes):
    monkeypatch.setattr(common, "usable_cores", lambda: cores)
    assert IMPROVED.solve_lanes == 2
    got = for_pool(IMPROVED, WorkerPool(workers, backend))
    assert got.solve_lanes == lanes
    assert got.to_dict() == {**IMPROVED.to_dict(), "solve_lanes": lanes}  # nothing else changed
    if lanes == IMPROVED.solve_lanes:
        assert got is IMPROVED


def test_a_users_lanes_are_the_most_a_worker_gets(monkeypatch):
    monkeypatch.setattr(common, "usable_cores", lambda: 16)
    one = IMPROVED.with_overrides(solve_lanes=1)
    assert for_pool(one, WorkerPool(1)).solve_lanes == 1
    four = IMPROVED.with_overrides(solve_lanes=4)
    assert for_pool(four, WorkerPool(2)).solve_lanes == 4 and for_pool(four, WorkerPool(8)).solve_lanes == 2


def test_lanes_are_not_a_change_of_the_planner():
    """The lanes change the planner's speed, not its answers (tests/test_lanes.py): the
    documents record them on their own, not among ``planner_changes``."""
    assert planner_changes(IMPROVED.with_overrides(solve_lanes=1)) == {}
    assert planner_changes(IMPROVED.with_overrides(solve_lanes=1, sample_time_s=0.25)) == {"sample_time_s": 0.25}


def test_the_documents_say_the_workers_and_lanes(tmp_path):
    """``gpcnav evaluate --workers 2`` runs each worker's planner with the cores left to it,
    and EVAL.json says so (the machine's cores counted here as the command counts them)."""
    out = tmp_path / "E.json"
    proc = subprocess.run([sys.executable, "-m", "gpcnav", "evaluate", "--suite", "random", "--count", "2", "--seed", "1",
                           "--controller", "stand", "--workers", "2", "--out", str(out)],
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    doc = json.loads(out.read_text())
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert doc["workers"] == 2
    assert doc["solve_lanes"] == max(1, min(IMPROVED.solve_lanes, cores // 2))
    assert "planner_changes" not in doc


def test_the_worker_count_defaults_to_the_cores_the_lanes_are_counted_from():
    """One count of the cores: ``--workers`` defaults to the cores the lanes are fitted to
    (CPU affinity, as a container's limits say), so the default run's lanes are one a worker."""
    import argparse

    from gpcnav.commands import dataset, evaluate, reproduce
    for add in (evaluate.add_pool_arguments, dataset.add_arguments, reproduce.add_arguments):
        p = argparse.ArgumentParser()
        add(p)
        assert p.get_default("workers") == common.usable_cores(), add
    assert for_pool(IMPROVED, WorkerPool(common.usable_cores())).solve_lanes == 1
