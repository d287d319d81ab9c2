"""tools/paper_nn_study.py's dataset subsets: the first shards that hold the samples asked
for, the manifest cut to match, and (``restamp``) today's `paper` configuration in it."""
from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np

from casadi_gpc.config import preset

ROOT = Path(__file__).resolve().parents[1]


def _tool():
    spec = importlib.util.spec_from_file_location("paper_nn_study", ROOT / "tools" / "paper_nn_study.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _dataset(folder: Path, sizes) -> None:
    folder.mkdir()
    names = []
    for i, n in enumerate(sizes):
        names.append(f"shard-{i:05d}.npz")
        np.savez(folder / names[-1], labels=np.full((n, 2), float(i)), features=np.zeros((n, 17)))
    man = {"samples": sum(sizes), "shards": names, "planner_config": {"name": "paper", "old": True},
           "parts": {"offpolicy": {"samples": sum(sizes), "shards": names}}}
    (folder / "manifest.json").write_text(json.dumps(man))


def test_subset_takes_whole_shards_in_order(tmp_path):
    study = _tool()
    _dataset(tmp_path / "d", [10, 10, 10])
    out = Path(study.subset(str(tmp_path / "d"), 15, tmp_path / "subsets"))
    man = json.loads((out / "manifest.json").read_text())
    assert out.name == "d@15" and man["samples"] == 20 and man["shards"] == ["shard-00000.npz", "shard-00001.npz"]
    assert man["parts"]["offpolicy"] == {"samples": 20, "shards": man["shards"]}
    assert man["planner_config"] == {"name": "paper", "old": True}  # no restamp: as labelled
    assert [float(np.load(out / s)["labels"][0, 0]) for s in man["shards"]] == [0.0, 1.0]
    assert not (out / "shard-00002.npz").exists()


def test_restamp_keeps_the_labelling_configuration(tmp_path):
    study = _tool()
    _dataset(tmp_path / "d", [10, 10])
    out = Path(study.subset(str(tmp_path / "d"), 10 ** 9, tmp_path / "subsets", restamp=True))
    man = json.loads((out / "manifest.json").read_text())
    assert man["samples"] == 20 and len(man["shards"]) == 2
    assert man["planner_config"] == json.loads(json.dumps(preset("paper").to_dict()))
    assert man["planner_config_labelled"] == {"name": "paper", "old": True}
