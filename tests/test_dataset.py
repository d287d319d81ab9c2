"""Datasets (nn_export.training.dataset, gpcnav dataset): manifest and shard contents, determinism
per (seed, shard), resuming after a SIGKILL with exactly the samples asked for and none
twice, refusal of mismatched arguments, on-policy (DAgger) parts."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from casadi_gpc.config import preset
from casadi_gpc.types import ControlDecision
from nn_export.training.dataset import (
    ARRAY_KEYS, DatasetMismatch, DatasetSpec, OnPolicyOptions, append_part, collect_on_policy, generate, load_dataset,
    read_manifest, read_shard,
)
from nn_export.runtime.features import compute_features
from nn_export.runtime.layouts import layout_for
from nn_export.training.labels import LABEL_NAMES, Labeller

PAPER = preset("paper")


def _spec(samples=60, shard=20, seed=3, **kw):
    return DatasetSpec(samples=samples, config=PAPER, layout=layout_for("paper", PAPER.horizon), seed=seed,
                       shard_size=shard, mirror_check_every=kw.pop("mirror_check_every", 0),
                       solver=Labeller(PAPER).solver, **kw)


def _all_arrays(directory: Path, keys=("features", "labels", "sample_id", "situation_id")) -> dict:
    man = read_manifest(directory)
    parts = [read_shard(directory / s, keys=keys) for s in man["shards"]]
    return {k: np.concatenate([p[k] for p in parts]) for k in keys}


@pytest.fixture(scope="module")
def reference_dataset(tmp_path_factory):
    """60 samples in 3 shards, written by one in-process worker."""
    out = tmp_path_factory.mktemp("ref") / "ds"
    man = generate(out, _spec(), workers=1)
    return out, man


def test_manifest_has_the_contract_fields(reference_dataset):
    out, man = reference_dataset
    assert man == read_manifest(out)
    assert man["samples"] == 60 and man["complete"] is True
    assert man["shards"] == ["shard-00000.npz", "shard-00001.npz", "shard-00002.npz"]
    lay = layout_for("paper", 6)
    assert man["feature_names"] == list(lay.feature_names) and len(man["feature_names"]) == 17
    assert man["label_names"] == list(LABEL_NAMES)
    assert man["feature_layout"]["name"] == "paper" and man["feature_layout"]["version"] == lay.version
    assert man["preset"] == "paper" and man["planner_config"]["sample_time_s"] == 1.5 and man["seed"] == 3
    for s in man["shards"]:
        a = read_shard(out / s)
        assert set(ARRAY_KEYS) <= set(a) and len(a["labels"]) == 20
        assert a["features"].shape == (20, 17) and a["plan_wheels_mps"].shape == (20, 6, 2)
        assert np.all(np.isfinite(a["features"])) and np.all(np.isfinite(a["labels"]))
        assert np.all(np.abs(a["labels"]) <= 0.8 + 1e-6)  # within the wheel limits
        np.testing.assert_array_equal(a["labels"], a["plan_wheels_mps"][:, 0])
    a = _all_arrays(out)
    assert len(np.unique(a["sample_id"])) == 60 and len(np.unique(a["situation_id"])) == 30
    ds = load_dataset(out)
    assert ds.X.shape == (60, 17) and ds.Y.shape == (60, 2) and ds.layout == lay
    np.testing.assert_array_equal(ds.groups, a["situation_id"])


def test_shard_contents_depend_only_on_seed_and_index(reference_dataset, tmp_path):
    out, _ = reference_dataset
    other = tmp_path / "two_workers"
    generate(other, _spec(), workers=2)
    for s in read_manifest(out)["shards"]:
        a, b = read_shard(out / s), read_shard(other / s)
        for k in ARRAY_KEYS:
            np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    # another seed gives other situations
    third = tmp_path / "seed4"
    generate(third, _spec(samples=20, seed=4), workers=1)
    assert not np.array_equal(read_shard(third / "shard-00000.npz")["features"],
                              read_shard(out / "shard-00000.npz")["features"])


def test_resume_redoes_only_missing_or_broken_shards(reference_dataset, tmp_path):
    src, _ = reference_dataset
    out = tmp_path / "ds"
    out.mkdir()
    for name in ("manifest.json", "shard-00000.npz", "shard-00001.npz", "shard-00002.npz"):
        (out / name).write_bytes((src / name).read_bytes())
    (out / "shard-00001.npz").unlink()                       # never finished
    (out / "shard-00002.npz").write_bytes(b"PK\x03\x04 truncated")  # broken (cannot be, but must not count)
    (out / ".shard-00001.npz.abc.tmp").write_bytes(b"half")  # a temporary of a killed run
    before = (out / "shard-00000.npz").stat().st_mtime_ns
    man = generate(out, _spec(), workers=1)
    run = man["parts"]["offpolicy"]["last_run"]
    assert run["resumed_shards"] == 1 and run["shards_done"] == 2 and run["stale_temporaries_removed"] == 1
    assert (out / "shard-00000.npz").stat().st_mtime_ns == before  # not redone
    assert man["samples"] == 60 and not list(out.glob(".*.tmp"))
    for s in man["shards"]:
        np.testing.assert_array_equal(read_shard(out / s)["features"], read_shard(src / s)["features"])
    # a finished dataset: nothing to do
    again = generate(out, _spec(), workers=1)
    assert again["parts"]["offpolicy"]["last_run"]["shards_done"] == 0


def test_other_arguments_are_refused(reference_dataset):
    out, _ = reference_dataset
    with pytest.raises(DatasetMismatch, match="seed"):
        generate(out, _spec(seed=9), workers=1)
    proc = subprocess.run([sys.executable, "-m", "gpcnav", "dataset", "--out", str(out), "--samples", "60",
                           "--shard-size", "20", "--preset", "paper", "--seed", "9", "--workers", "1"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert len(proc.stderr.strip().splitlines()) == 1 and "other arguments" in proc.stderr


@pytest.mark.parametrize("argv, words", [
    (["--samples", "0"], "--samples"),
    (["--samples", "10", "--shard-size", "7"], "--shard-size"),
    (["--samples", "10", "--workers", "0"], "--workers"),
    (["--samples", "10", "--address", "1.2.3.4:6379"], "--address"),
    (["--samples", "10", "--solver", "no-such-solver"], "--solver"),
    (["--dagger", "gpc", "--dagger-noise", "-0.1"], "--dagger-noise"),
    (["--dagger", "gpc", "--start-offset", "9"], "--start-offset"),
    (["--samples", "10", "--dagger-noise", "0.05"], "--dagger-noise"),
    (["--samples", "10", "--scheme", "two-pass", "--layout", "multi"], "--scheme"),
    (["--samples", "10", "--tie-margin", "1.5"], "--tie-margin"),
    (["--dagger", "gpc", "--scheme", "two-pass"], "--scheme"),
    (["--samples", "10", "--dagger-files", "a.toml"], "--dagger-files"),
    (["--dagger", "gpc", "--dagger-suite", "corridor", "--dagger-files", "a.toml"], "not both"),
    (["--dagger", "gpc", "--episodes", "3", "--dagger-files", "a.toml"], "--episodes does not apply"),
    # the contract's suite options (--suite, --count) are the round's; options a suite does not take were ignored
    (["--dagger", "gpc", "--suite", "random", "--count", "3", "--movers", "3"], "--movers: suite random has its own"),
    (["--dagger", "gpc", "--movers", "3"], "--movers: suite random has its own movers"),
    (["--dagger", "gpc", "--suite", "encounters", "--behaviour", "orca"], "--behaviour: suite encounters"),
    (["--dagger", "gpc", "--behaviour", "replay", "--dagger-files", "a.toml"], "runs the files as they are"),
    (["--samples", "10", "--movers", "3"], "need --dagger"),
    (["--samples", "10", "--count", "3"], "need --dagger"),
    # taken and ignored until 2026-12-01
    (["--samples", "10", "--round", "3"], "need --dagger"),
    (["--samples", "10", "--dagger-safety", "gpc"], "need --dagger"),
    (["--dagger", "gpc", "--samples", "10"], "--samples: a --dagger round adds the samples its episodes visit"),
    (["--dagger", "gpc", "--dagger-safety", "brake"], "--dagger-safety is for --dagger MODEL.onnx"),
    # taken and ignored until 2026-12-02: a round labels in its dataset's layout and appends one shard
    (["--dagger", "gpc", "--layout", "set"], "--layout applies to a new dataset: a --dagger round labels in its "
                                            "dataset's layout"),
    (["--dagger", "gpc", "--shard-size", "10"], "--shard-size applies to a new dataset"),
    (["--dagger", "gpc", "--layout", "paper", "--shard-size", "1000"], "--layout and --shard-size apply to a new"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, argv, words):
    proc = subprocess.run([sys.executable, "-m", "gpcnav", "dataset", "--out", str(tmp_path / "d"), *argv],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and words in proc.stderr
    assert not (tmp_path / "d" / "manifest.json").exists()


def _children(pid: int) -> list[int]:
    try:
        return [int(c) for c in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie is dead
        return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except OSError:
        return False


def test_sigkill_partway_then_restart_gives_exactly_the_samples(tmp_path):
    out = tmp_path / "ds"
    argv = [sys.executable, "-m", "gpcnav", "dataset", "--out", str(out), "--samples", "1200", "--shard-size", "30",
            "--workers", "2", "--preset", "paper", "--seed", "7", "--mirror-check-every", "0"]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while len(list(out.glob("shard-*.npz"))) < 3:
        assert proc.poll() is None, "finished before it could be killed: make the run longer"
        assert time.monotonic() < deadline
        time.sleep(0.05)
    workers = _children(proc.pid)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    finished = {p.name: p.stat().st_mtime_ns for p in out.glob("shard-*.npz")}
    assert 3 <= len(finished) < 40
    # the workers die with their parent, so nothing keeps computing or writing
    deadline = time.monotonic() + 10
    while any(_alive(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(_alive(w) for w in workers)
    man = read_manifest(out)
    assert man["samples"] <= 30 * len(finished) and not man["complete"]

    done = subprocess.run(argv, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    man = read_manifest(out)
    assert man["samples"] == 1200 and man["complete"] and len(man["shards"]) == 40
    run = man["parts"]["offpolicy"]["last_run"]
    assert run["resumed_shards"] == len(finished) and run["shards_done"] == 40 - len(finished)
    for name, mtime in finished.items():  # no finished shard was redone
        assert (out / name).stat().st_mtime_ns == mtime
    a = _all_arrays(out)  # every shard readable
    assert len(a["labels"]) == 1200
    assert len(np.unique(a["sample_id"])) == 1200
    assert len(np.unique(a["features"], axis=0)) == 1200
    assert not list(out.glob(".*.tmp"))


def _copy_dataset(src: Path, out: Path) -> Path:
    """A copy of the dataset folder ``src`` (its files, not lock or temporary ones) at ``out``."""
    out.mkdir()
    for p in src.iterdir():
        if p.is_file() and not p.name.startswith("."):
            (out / p.name).write_bytes(p.read_bytes())
    return out


class _SlowStraight:
    """A stand-in for a trained policy: drives straight at 0.3 m/s."""

    sample_time_s = PAPER.sample_time_s

    def reset(self):
        pass

    def decide(self, obs):
        return ControlDecision(0.3, 0.3)


def test_dagger_round_appends_labelled_on_policy_situations(reference_dataset, tmp_path):
    from dataclasses import replace
    from scenarios import random_suite
    src, _ = reference_dataset
    out = _copy_dataset(src, tmp_path / "ds")
    scenarios = [replace(s, duration_s=9.0) for s in random_suite("random", 2, 0)]  # 6 samples each
    lay = layout_for("paper", 6)
    lab = Labeller(PAPER)
    arrays, stats = collect_on_policy(_SlowStraight(), scenarios, OnPolicyOptions(PAPER, lay, id_base=10 ** 12), lab)
    assert stats["situations"] == 12 and len(stats["episodes"]) == 2
    assert stats["elapsed_s"] > 0  # the round's part recorded 0.0 s for any round
    n = len(arrays["labels"])
    assert n == 2 * (12 - stats["not_converged"])
    # the visited situations are what the deployed tracker sees: recompute the first one
    from scenarios.simulator import simulate
    from nn_export.runtime.tracker import SituationTracker
    seen = []

    class _Spy(_SlowStraight):
        def __init__(self):
            self.t = SituationTracker(PAPER)

        def reset(self):
            self.t.reset()

        def decide(self, obs):
            seen.append(self.t.update(obs))
            return super().decide(obs)

    simulate(scenarios[0], _Spy())
    np.testing.assert_array_equal(arrays["features"][0], compute_features(lay, seen[0]))
    man = append_part(out, "dagger1", arrays, stats, {"round": 1})
    assert man["samples"] == 60 + n and man["parts"]["dagger1"]["samples"] == n
    assert "dagger1-00000.npz" in man["shards"]
    ds = load_dataset(out)
    assert len(ds.X) == 60 + n and len(np.unique(ds.groups)) == 30 + n // 2
    with pytest.raises(DatasetMismatch):
        append_part(out, "dagger1", arrays, stats)
    # resuming the off-policy part keeps the on-policy part
    man = generate(out, _spec(), workers=1)
    assert man["samples"] == 60 + n and "dagger1" in man["parts"]


def test_driving_noise_perturbs_the_applied_speeds_only():
    """DART: the recorder adds N(0, sigma) to each wheel speed the driver asks for, counts it,
    and leaves the driver's own answer (and so the labels, made afresh) alone."""
    from nn_export.training.dataset.onpolicy import Recorder
    rec = Recorder(_SlowStraight(), PAPER, noise_mps=0.05, seed=3)
    from scenarios import random_suite
    from casadi_gpc.types import Observation
    sc = random_suite("random", 1, 0)[0]
    obs = Observation(0.0, sc.robot_start, sc.reference, (), ())
    T = PAPER.sample_time_s  # one decision a sample (the same place at each)
    got = np.array([[d.v_right_mps, d.v_left_mps] for d in (rec.decide(replace(obs, t_s=k * T)) for k in range(4000))])
    e = got - 0.3
    assert abs(e.mean()) < 0.004 and e.std() == pytest.approx(0.05, rel=0.05)
    assert abs(np.corrcoef(e[:, 0], e[:, 1])[0, 1]) < 0.05  # the two wheels independently
    assert rec.counters["driving_noise_applied"] == 4000
    quiet = Recorder(_SlowStraight(), PAPER)
    assert quiet.decide(obs).v_right_mps == 0.3 and "driving_noise_applied" not in quiet.counters


def test_noisy_episodes_visit_other_states_and_report_the_noise():
    from dataclasses import replace
    from scenarios import random_suite
    scenarios = [replace(s, duration_s=9.0) for s in random_suite("random", 1, 0)]
    lay, lab = layout_for("paper", 6), Labeller(PAPER)
    clean, st0 = collect_on_policy(_SlowStraight(), scenarios, OnPolicyOptions(PAPER, lay, mirror=False), lab)
    noisy, st1 = collect_on_policy(_SlowStraight(), scenarios,
                                   OnPolicyOptions(PAPER, lay, mirror=False, noise_mps=0.05, noise_seed=1), lab)
    assert st0["episodes"][0]["noise_applied"] == 0 and st1["episodes"][0]["noise_applied"] == 6
    np.testing.assert_array_equal(clean["features"][0], noisy["features"][0])  # before any noise acts
    assert np.max(np.abs(clean["features"][1:, :2] - noisy["features"][1:, :2])) > 0.01  # applied speeds differ


def test_perturb_start_moves_the_robot_sideways_within_the_bounds():
    from nn_export.training.dataset import perturb_start
    from scenarios import random_suite
    sc = random_suite("random", 1, 0)[0]
    rng = np.random.default_rng(0)
    for _ in range(50):
        s2 = perturb_start(sc, rng, 1.2, 0.6)
        r0, r1 = sc.robot_start, s2.robot_start
        dx, dy = r1.x_m - r0.x_m, r1.y_m - r0.y_m
        along = dx * np.cos(r0.heading_rad) + dy * np.sin(r0.heading_rad)
        assert abs(along) < 1e-12 and np.hypot(dx, dy) <= 1.2
        assert abs(r1.heading_rad - r0.heading_rad) <= 0.6
    assert perturb_start(sc, rng, 0.0, 0.0) is sc


def _spin(n: int) -> int:
    """Pure CPU work (no memory traffic, no I/O): the machine's own parallel speed-up."""
    total = 0
    for i in range(n):
        total += i * i
    return total


def _machine_speedup(n: int) -> float:
    """How much faster two forked processes do two units of :func:`_spin` than one process
    does them one after the other, right now: 2 on an idle 2-core machine, near 1 when
    another job holds a core."""
    import multiprocessing as mp
    ctx = mp.get_context("fork")
    t0 = time.perf_counter()
    _spin(n)
    _spin(n)
    serial = time.perf_counter() - t0
    t0 = time.perf_counter()
    procs = [ctx.Process(target=_spin, args=(n,)) for _ in range(2)]
    for pr in procs:
        pr.start()
    for pr in procs:
        pr.join()
    return serial / (time.perf_counter() - t0)


@pytest.mark.slow
@pytest.mark.benchmark
def test_two_workers_speed_labelling_up_as_the_machine_allows(tmp_path):
    """Two workers label as fast as two plain processes compute, within a margin: the
    speed-up of two workers over one, measured in one run (paper preset), is at least 0.75
    of what two forked CPU-bound processes get on the machine at that moment. On an idle
    2-core machine that is the issue's 1.5x (measured 1.7x, docs); on a busy one, where
    another job holds a core, the machine's own speed-up falls and the bar with it, so the
    test fails only when the pool, not the load, is slow. Best of three interleaved blocks,
    each with the machine measured before and after, as benchmarks do."""
    spin = 10_000_000
    blocks = []
    for trial in range(3):
        before = _machine_speedup(spin)
        rates = {}
        for w in (1, 2):
            t0 = time.perf_counter()
            man = generate(tmp_path / f"w{w}-{trial}", _spec(samples=4000, shard=200, seed=11), workers=w)
            rates[w] = man["samples"] / (time.perf_counter() - t0)
        machine = 0.5 * (before + _machine_speedup(spin))
        blocks.append({"speedup": rates[2] / rates[1], "machine_speedup": machine,
                       "efficiency": rates[2] / rates[1] / machine, "rates": rates})
    print(json.dumps(blocks))
    best = max(blocks, key=lambda b: b["efficiency"])
    assert best["efficiency"] >= 0.75, blocks


@pytest.mark.slow  # kept out of the default suite for its time (CI: under 10 minutes)
def test_cli_dagger_round_with_a_trained_network(reference_dataset, tmp_path):
    """The whole loop through the command line: train a tiny network on the dataset, export
    it, and let ``gpcnav dataset --dagger`` append what the GPC says in the states it visits."""
    pytest.importorskip("torch")
    pytest.importorskip("onnx")
    src, _ = reference_dataset
    out = _copy_dataset(src, tmp_path / "ds")

    def gpcnav(*argv):
        proc = subprocess.run([sys.executable, "-m", "gpcnav", *map(str, argv)], capture_output=True, text=True,
                              timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        return proc

    gpcnav("train", out, "--out", tmp_path / "model", "--epochs", "3", "--hidden", "8", "--preset", "paper")
    gpcnav("export", tmp_path / "model", "--out", tmp_path / "m.onnx")
    gpcnav("dataset", "--out", out, "--dagger", tmp_path / "m.onnx", "--episodes", "2", "--preset", "paper",
           "--workers", "2")
    man = read_manifest(out)
    part = man["parts"]["dagger1"]
    assert part["samples"] > 0 and man["samples"] == 60 + part["samples"]
    assert part["info"]["model"].endswith("m.onnx") and part["episodes"] == 2
    assert part["info"]["safety_filter"] == "off"  # the bare network drives by default
    ds = load_dataset(out)
    assert len(ds.X) == man["samples"] and len(np.unique(ds.groups)) == len(ds.X) // 2
    # the same round again is refused (one line, exit 2)
    proc = subprocess.run([sys.executable, "-m", "gpcnav", "dataset", "--out", str(out), "--dagger",
                           str(tmp_path / "m.onnx"), "--episodes", "2", "--preset", "paper"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1
    # the GPC itself drives a round: its own closed-loop states, in part gpc1 (the contract's spelling
    # of the suite, --suite NAME --count N, as evaluate's)
    gpcnav("dataset", "--out", out, "--dagger", "gpc", "--suite", "random", "--count", "1", "--preset", "paper",
           "--workers", "1")
    man2 = read_manifest(out)
    gpc_part = man2["parts"]["gpc1"]
    assert gpc_part["info"]["suite"] == "random" and gpc_part["episodes"] == 1
    assert gpc_part["samples"] > 0 and gpc_part["info"]["safety_filter"] is None
    assert man2["samples"] == man["samples"] + gpc_part["samples"]
    assert gpc_part["info"]["suite_seed"] != part["info"]["suite_seed"]
    # a round labelled with other planner settings is refused before any work (one line, exit 2)
    proc = subprocess.run([sys.executable, "-m", "gpcnav", "dataset", "--out", str(out), "--dagger", "gpc",
                           "--episodes", "1", "--round", "2", "--preset", "paper", "--set", "tracking_weight=2"],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "tracking_weight differ" in proc.stderr, proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and read_manifest(out) == man2


def test_dagger_round_on_scenario_files(reference_dataset, tmp_path):
    """``--dagger-files``: the round's episodes are the files given, one each, in their order
    (the part records their names); a file that is not a scenario is refused in one line,
    exit 2, before any work."""
    from casadi_gpc.robot import RobotParams
    from gpcnav.controllers import make_controller
    from scenarios import PAPER_DIR, load_scenario
    from scenarios.simulator import simulate
    src, _ = reference_dataset
    out = _copy_dataset(src, tmp_path / "ds")
    files = [PAPER_DIR / "fig7_1_head_on.toml", PAPER_DIR / "fig7_2_crossing.toml"]
    bad = tmp_path / "bad.toml"
    bad.write_text("[robot]\nposition = [0, 0\n")
    argv = [sys.executable, "-m", "gpcnav", "dataset", "--out", str(out), "--dagger", "gpc", "--preset", "paper",
            "--workers", "1", "--dagger-files"]
    proc = subprocess.run([*argv, str(files[0]), str(bad)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and "bad.toml" in proc.stderr
    assert read_manifest(out)["samples"] == 60
    proc = subprocess.run([*argv, *map(str, files)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    part = read_manifest(out)["parts"]["gpc1"]
    assert part["info"]["suite"] == "files" and part["episodes"] == 2
    assert part["info"]["files"] == ["fig7_1_head_on", "fig7_2_crossing"]
    shard = np.load(out / part["shards"][0], allow_pickle=True)
    steps = [len(simulate(load_scenario(f), make_controller("gpc", PAPER, RobotParams()), "gpc").decisions)
             for f in files]
    assert part["samples"] == len(shard["labels"]) == 2 * sum(steps)  # each situation and its mirror image


def test_dagger_files_of_another_robot_are_refused(reference_dataset, tmp_path):
    """A ``--dagger-files`` file whose ``[robot]`` is not the dataset's robot (its wheel base,
    a larger disc) is refused in one line naming it and the fields, exit 2, nothing appended:
    its episode moved that robot while the GPC labelled (and the network drove) the dataset's
    (it ran, exit 0, until 2026-11-30)."""
    from scenarios import PAPER_DIR
    src, _ = reference_dataset
    out = _copy_dataset(src, tmp_path / "ds")
    before = read_manifest(out)
    text = (PAPER_DIR / "fig7_2_crossing.toml").read_text()
    other = tmp_path / "other_robot.toml"
    other.write_text(text.replace("[robot]\n", "[robot]\nwheel_base_m = 0.3\nradius_m = 0.5\n", 1))
    argv = [sys.executable, "-m", "gpcnav", "dataset", "--out", str(out), "--dagger", "gpc", "--preset", "paper",
            "--workers", "1", "--dagger-files", str(PAPER_DIR / "fig7_1_head_on.toml"), str(other)]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr[-2000:]
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "other_robot.toml" in lines[0], proc.stderr
    assert "wheel_base_m 0.3 vs 0.5" in lines[0] and "radius_m 0.5 vs 0.35" in lines[0]
    assert read_manifest(out) == before


@pytest.mark.slow  # kept out of the default suite for its time (CI: under 10 minutes)
def test_train_on_some_parts_only(reference_dataset, tmp_path):
    """gpcnav train --parts: the model is fitted on the named parts only (its provenance says
    which and how many samples); an unknown part is refused with one line, exit 2."""
    pytest.importorskip("torch")
    src, _ = reference_dataset
    out = _copy_dataset(src, tmp_path / "ds")
    from dataclasses import replace
    from scenarios import random_suite
    scenarios = [replace(s, duration_s=9.0) for s in random_suite("random", 2, 0)]
    arrays, stats = collect_on_policy(_SlowStraight(), scenarios, OnPolicyOptions(PAPER, layout_for("paper", 6),
                                                                                  id_base=10 ** 12), Labeller(PAPER))
    append_part(out, "dagger1", arrays, stats, {"round": 1})

    def train(parts, dest):
        argv = [sys.executable, "-m", "gpcnav", "train", str(out), "--out", str(dest), "--preset", "paper",
                "--hidden", "4", "--epochs", "3", "--seed", "0"] + (["--parts", parts] if parts else [])
        return subprocess.run(argv, capture_output=True, text=True, timeout=300)

    for parts, n in (("offpolicy", 60), (None, 60 + len(arrays["labels"]))):
        proc = train(parts, tmp_path / f"m_{parts}")
        assert proc.returncode == 0, proc.stderr
        prov = json.loads((tmp_path / f"m_{parts}" / "model.json").read_text())["provenance"]["dataset"]
        assert prov["samples"] == n
        assert prov["parts"][str(out)] == (["offpolicy"] if parts else ["dagger1", "offpolicy"])
    ids = {json.loads((tmp_path / f"m_{parts}" / "model.json").read_text())["provenance"]["dataset"]["id"]
           for parts in ("offpolicy", None)}
    assert len(ids) == 2  # other samples trained on, another dataset id
    proc = train("offpolicy,gpc9", tmp_path / "bad")
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and "gpc9" in proc.stderr
    assert not (tmp_path / "bad").exists()


def test_the_dataset_id_of_a_training_says_which_parts_it_took():
    """train's dataset id hashed every part of the manifest whatever ``--parts`` said: two
    models trained on other parts of one folder had the same id. Naming every part is the
    same data (the same id); another choice of parts, another id."""
    from gpcnav.commands.train import _dataset_id
    man = {"samples": 100, "shards": ["a.npz", "b.npz"], "seed": 3,
           "parts": {"offpolicy": {"samples": 60, "shards": ["a.npz"]},
                     "dagger1": {"samples": 40, "shards": ["b.npz"]}}}
    every = _dataset_id([man])
    assert _dataset_id([man], ("dagger1", "offpolicy")) == _dataset_id([man], ("offpolicy", "dagger1")) == every
    ids = {every, _dataset_id([man], ("offpolicy",)), _dataset_id([man], ("dagger1",))}
    assert len(ids) == 3
    assert _dataset_id([man, man], ("offpolicy",)) != _dataset_id([man], ("offpolicy",))  # and every folder counts


def test_every_sampler_number_is_part_of_the_spec_id(reference_dataset):
    """Every number the sampler draws with is a SamplerSettings field: changing one changes
    the spec_id, and a resume with it is refused (its situations would be drawn otherwise)."""
    from dataclasses import replace
    out, _ = reference_dataset
    base = _spec()
    other = replace(base, sampler=replace(base.sampler, tracking_lateral_std_m=0.2))
    assert other.spec_id != base.spec_id
    with pytest.raises(DatasetMismatch, match="sampler"):
        generate(out, other, workers=1)


def test_every_sampler_setting_is_drawn_with():
    """Each field of SamplerSettings is read by the sampler (none is decoration), and the
    sampler's body names no distribution of its own: its uniform and normal draws take
    their bounds from the settings."""
    import inspect
    import re
    from dataclasses import fields

    from nn_export.training import sampler
    source = inspect.getsource(sampler).split("class _Mover", 1)[1]
    for f in fields(sampler.SamplerSettings):
        assert re.search(rf"\bst\.{f.name}\b", source), f.name
    for call in re.findall(r"rng\.(?:uniform|normal|integers)\(([^()]*(?:\([^()]*\)[^()]*)*)\)", source):
        # no number of its own but a zero mean or bound and the full circle (2 pi, 360 deg)
        assert set(re.findall(r"\d+(?:\.\d*)?", call)) <= {"0", "0.0", "1", "2", "360.0"}, call


def test_damaged_manifest_is_rebuilt_from_the_shards(reference_dataset, tmp_path):
    """A manifest.json that is not JSON loses nothing: the run says so in one line, reuses
    every finished shard (untouched), labels only the missing one, and writes the manifest
    anew; with other arguments it refuses in one line instead of writing over the shards."""
    src, man0 = reference_dataset
    out = _copy_dataset(src, tmp_path / "ds")
    (out / "manifest.json").write_text('{"samples": 60, "shards": [')  # cut off mid-write by hand
    (out / "shard-00002.npz").unlink()
    kept = {n: (out / n).stat().st_mtime_ns for n in ("shard-00000.npz", "shard-00001.npz")}
    base = [sys.executable, "-m", "gpcnav", "dataset", "--out", str(out), "--samples", "60", "--shard-size", "20",
            "--preset", "paper", "--workers", "1", "--mirror-check-every", "0"]
    proc = subprocess.run(base + ["--seed", "4"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "damaged" in proc.stderr and "other arguments" in proc.stderr
    proc = subprocess.run(base + ["--seed", "3"], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert [line for line in proc.stderr.splitlines() if "damaged" in line] == [
        "gpcnav dataset: manifest.json was damaged (JSONDecodeError): rebuilt from the shards, finished shards reused"]
    man = read_manifest(out)
    assert man["samples"] == 60 and man["shards"] == man0["shards"]
    assert man["parts"]["offpolicy"]["last_run"]["resumed_shards"] == 2
    assert man["parts"]["offpolicy"]["last_run"]["shards_done"] == 1
    assert {n: (out / n).stat().st_mtime_ns for n in kept} == kept  # reused, not relabelled
    for s in man["shards"]:
        np.testing.assert_array_equal(read_shard(out / s)["features"], read_shard(src / s)["features"])


def test_train_says_when_its_dataset_is_unfinished(reference_dataset, tmp_path, capsys):
    """A dataset whose run stopped (its manifest: complete false, fewer samples than asked) was
    trained on without a word."""
    import json
    from gpcnav.cli import main
    src, _ = reference_dataset
    out = tmp_path / "ds"
    out.mkdir()
    for f in src.iterdir():
        (out / f.name).write_bytes(f.read_bytes())
    man = json.loads((out / "manifest.json").read_text())
    assert main(["train", str(out), "--out", str(tmp_path / "m0"), "--preset", "paper", "--epochs", "1"]) == 0
    assert "warning" not in capsys.readouterr().err  # a finished dataset: nothing to say
    man.update(complete=False, samples_requested=120)
    for part in man.get("parts", {}).values():
        part["complete"] = False
    (out / "manifest.json").write_text(json.dumps(man))
    assert main(["train", str(out), "--out", str(tmp_path / "m1"), "--preset", "paper", "--epochs", "1"]) == 0
    err = capsys.readouterr().err
    assert f"gpcnav train: warning: {out} holds 60 of the 120 samples asked" in err


def test_train_refuses_a_dataset_folder_given_twice(reference_dataset, tmp_path, capsys):
    """``train d ./d`` trained on every sample twice, the copies of one situation with other
    ids: some in training and some in validation, the validation error measured on samples
    trained on."""
    from gpcnav.cli import main
    src, _ = reference_dataset
    (tmp_path / "link").symlink_to(src)
    for second in (src, Path(f"{src}/."), tmp_path / "link"):
        assert main(["train", str(src), str(second), "--out", str(tmp_path / "m"), "--preset", "paper",
                     "--epochs", "1"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err == [f"gpcnav train: error: {second}: the same dataset folder as {src}, given twice (its samples "
                       f"would be both trained on and validated on)"]
    assert not (tmp_path / "m").exists()


def test_train_on_a_damaged_shard_is_one_line(reference_dataset, tmp_path, capsys):
    """A shard cut short (a copy interrupted, a damaged disk) was a BadZipFile traceback."""
    from gpcnav.cli import main
    src, man = reference_dataset
    out = _copy_dataset(src, tmp_path / "ds")
    shard = out / man["shards"][1]
    for damaged in (shard.read_bytes()[:3000], shard.read_bytes()[:-40], b"not a shard"):
        shard.write_bytes(damaged)
        assert main(["train", str(out), "--out", str(tmp_path / "m"), "--preset", "paper", "--epochs", "1"]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"gpcnav train: error: {out}: cannot read the dataset: "
                                                   f"{shard.name}: not a readable shard ("), err
        assert err[0].endswith("`gpcnav dataset` with the same arguments redoes a damaged shard")
    assert not (tmp_path / "m").exists()


def test_train_on_a_manifest_without_a_field_names_the_field(reference_dataset, tmp_path, capsys):
    """It said only ``'feature_layout'`` (a KeyError's text)."""
    from gpcnav.cli import main
    src, _ = reference_dataset
    out = _copy_dataset(src, tmp_path / "ds")
    man = json.loads((out / "manifest.json").read_text())
    del man["feature_layout"]
    (out / "manifest.json").write_text(json.dumps(man))
    assert main(["train", str(out), "--out", str(tmp_path / "m"), "--preset", "paper", "--epochs", "1"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"gpcnav train: error: {out}: cannot read the dataset: its manifest.json has no 'feature_layout'"]


def test_dagger_episodes_with_walls_for_a_layout_without_walls_are_refused(reference_dataset, tmp_path, capsys):
    """A round with walls (``--dagger-files`` with ``[[walls]]``, ``--dagger-suite corridor``)
    on a dataset whose layout reads no walls stopped at its first situation with a ValueError
    traceback ("a situation with walls needs a planner with wall slots")."""
    from gpcnav.cli import main
    from scenarios import PAPER_DIR
    src, _ = reference_dataset
    out = _copy_dataset(src, tmp_path / "ds")
    before = read_manifest(out)
    walled = tmp_path / "walled.toml"
    walled.write_text((PAPER_DIR / "fig7_2_crossing.toml").read_text()
                      + "\n[[walls]]\npoints = [[-1.0, 2.0], [12.0, 2.0]]\n")
    base = ["dataset", "--out", str(out), "--dagger", "gpc", "--preset", "paper", "--workers", "1"]
    for extra, where in (
            (["--dagger-files", str(PAPER_DIR / "fig7_1_head_on.toml"), str(walled)], f"{walled}: has walls"),
            (["--dagger-suite", "corridor", "--episodes", "1"], "--suite corridor: its episodes have walls")):
        assert main(base + extra) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert err == [f"gpcnav dataset: error: {where}, and the dataset's layout 'paper' does not read walls (its "
                       f"labels are planned without them): a round with walls goes to a dataset of --layout "
                       f"set-walls"], err
    assert read_manifest(out) == before
