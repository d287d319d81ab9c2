"""``gpcnav reproduce --preset``: every stage command runs under the run's preset, the network
just trained is the one that preset's rows run, the other preset's rows (full run) run the
network shipped for it, and the report speaks of the run's preset
(gpcnav/commands/reproduce.py, reproduce_report.py). The stages' commands are recorded, not
run: their own tests run them."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from gpcnav import cli
from gpcnav.commands import reproduce
from gpcnav.commands.reproduce_report import comparison, fig7_rows
from scenarios import PAPER_NAMES


class _Recorder:
    """Runs every stage (no key kept) and records each stage command's argv as strings."""

    def __init__(self, monkeypatch):
        self.argv: list[list[str]] = []
        monkeypatch.setattr(reproduce, "_cli", lambda argv: self.argv.append([str(a) for a in argv]))

    def run(self, name, inputs, outputs, fn):
        fn()

    def key(self, name):
        return ""


def _option(argv: list[str], name: str) -> str | None:
    return argv[argv.index(name) + 1] if name in argv else None


@pytest.mark.parametrize("trained", ["paper", "improved"])
def test_labels_training_and_bench_run_under_the_runs_preset(trained, monkeypatch, tmp_path):
    rec = _Recorder(monkeypatch)
    onnx = reproduce._label_train_export(rec, tmp_path, reproduce.QUICK, 3, 1, trained)
    reproduce._bench(rec, tmp_path, onnx, "key", trained)
    commands = [a[0] for a in rec.argv]
    assert commands == ["dataset", "train", "export", "bench"]
    for argv in rec.argv:
        if argv[0] != "export":  # (export reads the preset from the model)
            assert _option(argv, "--preset") == trained, argv
    assert _option(rec.argv[-1], "--model") == str(onnx)


@pytest.mark.parametrize("presets, trained", [(("paper",), "paper"), (("improved",), "improved"),
                                               (("paper", "improved"), "paper"), (("paper", "improved"), "improved")])
def test_the_network_just_trained_runs_the_runs_preset_only(presets, trained, monkeypatch, tmp_path):
    rec = _Recorder(monkeypatch)
    onnx = tmp_path / "model.onnx"
    files = reproduce._scenario_runs(rec, tmp_path, onnx, "key", presets, trained)
    evals = reproduce._suite_runs(rec, tmp_path, onnx, "key", 4, 1, 1, presets, trained)
    assert {k[0] for k in files} == {k[0] for k in evals} == set(presets)
    # the network shipped for `paper`, bare, beside the one just trained for it: only when `paper` is trained
    assert {k[2] for k in files if k[2] == "shipped"} == ({"shipped"} if trained == "paper" else set())
    assert len(rec.argv) == len(files) + len(evals)
    for argv in rec.argv:
        ctrl, preset = _option(argv, "--controller"), _option(argv, "--preset")
        assert preset in presets
        if ctrl == "gpc" or preset != trained:
            assert _option(argv, "--model") is None, argv  # the GPC, or the other preset's shipped network
    trained_nn = [a for a in rec.argv if _option(a, "--controller") == "nn" and _option(a, "--preset") == trained]
    with_model = [a for a in trained_nn if _option(a, "--model") == str(onnx)]
    # every Fig. 7 network row of the trained preset (bare and behind the filter) and its suite row
    assert len(with_model) == 2 * len(PAPER_NAMES) + 1
    assert len(trained_nn) - len(with_model) == (len(PAPER_NAMES) if trained == "paper" else 0)  # `shipped`


def test_the_scheme_limit_runs_under_the_runs_preset(monkeypatch, tmp_path):
    """The two-pass scheme with the GPC in place of the network is made with the run's preset."""
    seen = []

    class _Stop(Exception):
        pass

    def fake_preset(name):
        seen.append(name)
        raise _Stop

    import casadi_gpc.config
    monkeypatch.setattr(casadi_gpc.config, "preset", fake_preset)
    rec = _Recorder(monkeypatch)
    with pytest.raises(_Stop):
        reproduce._scheme_limit(rec, tmp_path, reproduce.QUICK, "improved")
    assert seen == ["improved"]


def test_an_unknown_preset_is_one_line(capsys, tmp_path):
    with pytest.raises(SystemExit) as stopped:  # (argparse's own refusal, as every subcommand's)
        cli.main(["reproduce", "--quick", "--preset", "nope", "--out", str(tmp_path / "out")])
    assert stopped.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("gpcnav reproduce: error: argument --preset") and "nope" in err[0]
    assert not (tmp_path / "out").exists()


def _doc(outcome: str = "reached_goal") -> dict:
    n = 5
    return {"trajectory": {"x": [0.0, 1.0, 2.0, 3.0, 4.0], "y": [0.0] * n}, "outcome": outcome,
            "min_clearance_m": 0.5, "tracking_rmse_m": 0.1, "time_to_goal_s": 30.0, "fallbacks": 0,
            "compute_time_s": {"median": 0.001},
            "obstacles": [{"kind": "static", "radius_m": 0.3, "x": [2.0] * n, "y": [3.0] * n}]}


def test_the_report_speaks_of_the_runs_preset(tmp_path):
    files = {}
    for preset in ("paper", "improved"):
        for name in PAPER_NAMES:
            for ctrl in ("gpc", "nn", "nn+filter"):
                path = tmp_path / f"{name}_{preset}_{ctrl}.json"
                path.write_text(json.dumps(_doc()))
                files[(preset, name, ctrl)] = Path(path)
    rows = fig7_rows(files, None, "improved")
    r = {"preset": "improved", "network": "23-35-2", "scenarios": rows, "suite": [], "seed": 0,
         "sizes": reproduce.QUICK.__dict__, "claim": _claim(rows, "improved")}
    text = comparison(r)
    assert "`improved` preset" in text and "`paper` preset, T = 1.5 s" not in text
    assert "23-35-2" in text and "17-35-2 network" not in text
    # the `paper` rows here are the shipped network's: no bullet reads them as the run's
    assert "The shipped network (`improved` rows)" not in text


def _claim(rows, preset):
    from gpcnav.commands.reproduce_report import claim
    c = claim(rows, True, "nn", preset)
    assert set(c["scenarios"]) == set(PAPER_NAMES)  # the run's preset's rows, not the other's
    return c


def test_the_report_names_the_network_that_was_trained(tmp_path):
    """The report named the trained network ``<inputs>-35-2``, a copy of ``gpcnav train``'s
    defaults, whatever was trained (and results.json's ``model`` looked for ``hidden`` beside
    ``params``, not in it, so it never had it). Now read from model.json, or from the
    exported file where the model folder is gone."""
    import shutil
    from gpcnav.commands.reproduce_report import network_shape
    from nn_export import shipped_model_path
    assert network_shape(tmp_path, {"params": {"hidden": 8, "layers": 2}, "n_outputs": 2}, 17) == "17-8-8-2"
    assert network_shape(tmp_path, {"params": {"hidden": 35, "layers": 1}, "n_outputs": 2}, 23) == "23-35-2"
    shutil.copyfile(shipped_model_path("paper"), tmp_path / "model.onnx")  # README: 17-64-64-64-2
    assert network_shape(tmp_path, {}, 17) == "17-64-64-64-2"
