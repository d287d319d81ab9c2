"""The same scenario files run again with only the sensor's noise drawn anew: how much of a
file-based result is the measurement noise's.

Run ``r`` (0 .. ``--repeats`` - 1) evaluates copies of the files whose ``[sensing] seed`` is the
file's own plus ``r * SEED_STEP`` (run 0: the files as they are); nothing else in them changes.
Each run is a ``gpcnav evaluate`` of its own (resumable as every evaluation is), and the
summary says per run how many episodes reached the goal, collided and timed out, and per
episode whether every run gave it the same outcome. On navground's ``Corridor`` a quarter of
the episodes changed outcome with the noise alone (docs/buildings.md, "How far one run of
navground's corridor can be trusted"): a rule that compares one run of a change with one run
of the shipped code there measures that noise as much as the change.

Usage::

    python tools/noise_repeats.py FILE.toml ... --out DIR [--repeats 3] [-- EVALUATE_ARGS ...]

e.g. ``python tools/noise_repeats.py out/ng/*.toml --out out/ng-noise -- --controller gpc --workers 2``.
Writes ``DIR/run-R/`` (the files and ``EVAL.json``) and ``DIR/SUMMARY.json``; exit 2 with one line
on a bad file or argument.
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from casadi_gpc.io import write_json  # noqa: E402  (atomic: never a half-written summary)
from scenarios import load_scenario  # noqa: E402

SEED_STEP = 1_000_003
"""What run ``r`` adds to each file's sensor seed, times ``r`` (a prime: the runs' seeds stay
apart whatever seeds the files hold)."""

_SEED = re.compile(r"^(\s*seed\s*=\s*)(\d+)(\s*(#.*)?)$")
_TABLE = re.compile(r"^\s*\[\[?\s*([A-Za-z0-9_.\-]+)\s*\]\]?\s*(#.*)?$")


def with_sensor_seed(text: str, seed: int) -> str:
    """The scenario file ``text`` with its ``[sensing] seed`` set to ``seed`` (the table and
    the key added where the file has none); every other line as it was."""
    lines = text.splitlines()
    table, start = None, None
    for i, line in enumerate(lines):
        m = _TABLE.match(line)
        if m:
            table = m.group(1)
            if table == "sensing":
                start = i
            continue
        if table == "sensing":
            s = _SEED.match(line)
            if s:
                lines[i] = f"{s.group(1)}{seed}{s.group(3)}"
                return "\n".join(lines) + "\n"
    if start is not None:
        lines.insert(start + 1, f"seed = {seed}")
    else:
        lines += ["", "[sensing]", f"seed = {seed}"]
    return "\n".join(lines) + "\n"


def write_run(files: list[Path], folder: Path, r: int) -> list[Path]:
    """Copies of ``files`` in ``folder`` with the sensor seeds of run ``r`` (checked: each copy
    loads, with that seed and otherwise the original's scenario)."""
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    for f in files:
        original = load_scenario(f)
        target = folder / f.name
        target.write_text(with_sensor_seed(f.read_text(), original.sensing.seed + r * SEED_STEP))
        copy = load_scenario(target)
        if copy.sensing.seed != original.sensing.seed + r * SEED_STEP or copy.name != original.name:
            raise ValueError(f"{f}: its copy for run {r} did not take the seed")
        out.append(target)
    return out


def summary(docs: list[dict]) -> dict:
    """Per run the outcome counts; per episode whether every run gave it the same outcome."""
    runs = [{k: sum(e["outcome"] == k for e in d["episodes_detail"]) for k in ("reached_goal", "collided", "timed_out")}
            for d in docs]
    by_episode = [[e["outcome"] for e in d["episodes_detail"]] for d in docs]
    names = [[e["scenario"] for e in d["episodes_detail"]] for d in docs]
    if any(n != names[0] for n in names):
        raise ValueError("the runs do not hold the same episodes in the same order")
    same = sum(len(set(o)) == 1 for o in zip(*by_episode))
    changed = [n for n, *o in zip(names[0], *by_episode) if len(set(o)) > 1]
    return {"runs": runs, "episodes": len(names[0]), "same_outcome_in_every_run": same,
            "changed": changed, "seed_step": SEED_STEP}


def main(argv: list[str]) -> int:
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("files", nargs="+", type=Path)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--repeats", type=int, default=3)
    a = p.parse_args(argv)
    if a.repeats < 2:
        print("noise_repeats: --repeats must be at least 2", file=sys.stderr)
        return 2
    try:
        docs = []
        for r in range(a.repeats):
            folder = a.out / f"run-{r}"
            files = write_run(a.files, folder, r)
            cmd = [sys.executable, "-m", "gpcnav", "evaluate", *map(str, files), *extra, "--out", str(folder / "EVAL.json")]
            done = subprocess.run(cmd)
            if done.returncode != 0:
                print(f"noise_repeats: run {r} failed (exit {done.returncode})", file=sys.stderr)
                return done.returncode
            docs.append(json.loads((folder / "EVAL.json").read_text()))
        s = summary(docs)
    except (OSError, ValueError) as exc:
        print(f"noise_repeats: {exc}", file=sys.stderr)
        return 2
    write_json(a.out / "SUMMARY.json", s)
    for r, c in enumerate(s["runs"]):
        print(f"run {r}: {c['reached_goal']} reached / {c['collided']} collided / {c['timed_out']} timed out")
    print(f"{s['same_outcome_in_every_run']} of {s['episodes']} episodes had the same outcome in every run")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
