"""Two runs of the same episodes, compared episode by episode: how many changed outcome, and
how surprising the changes are if the two controllers were equally good.

A run of a controller on a suite and a run of a changed one on the same episodes are paired:
most episodes end the same way, and what tells the two apart is the episodes that changed.
For each outcome (reached the goal, collided) the episodes that gained it and those that lost
it are counted, and the exact two-sided sign test (McNemar's test, exact form) gives the
chance of a split at least as uneven were a change equally likely either way. A rule that sums
goals over episodes where a quarter of the outcomes move each way (navground's corridor,
docs/buildings.md) is decided by that noise; this says how much.

Usage::

    python tools/paired.py BASE.json NEW.json [BASE2.json NEW2.json ...]

Each file an EVAL.json of ``gpcnav evaluate`` (or one controller of a COMPARE.json's
``controllers``); the pairs' counts are also summed over all pairs given.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from scipy.stats import binomtest

OUTCOMES = ("reached_goal", "collided")


def outcomes(path: str) -> dict[str, str]:
    """Scenario name -> outcome, from an EVAL.json."""
    doc = json.loads(Path(path).read_text())
    return {e["scenario"]: e["outcome"] for e in doc["episodes_detail"]}


def changes(base: dict[str, str], new: dict[str, str]) -> dict[str, tuple[int, int]]:
    """For each outcome, (episodes that gained it, episodes that lost it) from ``base`` to
    ``new``; the two must hold the same scenarios."""
    if set(base) != set(new):
        raise ValueError(f"not the same episodes: {len(set(base) ^ set(new))} scenarios in one run only")
    return {o: (sum(new[k] == o != base[k] for k in base), sum(base[k] == o != new[k] for k in base))
            for o in OUTCOMES}


def sign_test(gained: int, lost: int) -> float:
    """Two-sided exact sign test of ``gained`` against ``lost`` (1.0 when nothing changed)."""
    n = gained + lost
    return 1.0 if n == 0 else float(binomtest(gained, n, 0.5).pvalue)


def line(label: str, ch: dict[str, tuple[int, int]], n: int) -> str:
    parts = [f"{o}: +{g} -{l} (p = {sign_test(g, l):.3g})" for o, (g, l) in ch.items()]
    return f"{label} ({n} episodes): " + "; ".join(parts)


def main(argv: list[str]) -> int:
    if len(argv) < 2 or len(argv) % 2:
        print("usage: python tools/paired.py BASE.json NEW.json [BASE2.json NEW2.json ...]", file=sys.stderr)
        return 2
    total = {o: [0, 0] for o in OUTCOMES}
    episodes = 0
    for a, b in zip(argv[::2], argv[1::2]):
        try:
            base, new = outcomes(a), outcomes(b)
            ch = changes(base, new)
        except (OSError, ValueError, KeyError) as exc:
            print(f"{a} / {b}: {exc}", file=sys.stderr)
            return 2
        episodes += len(base)
        print(line(f"{Path(a).name} -> {Path(b).name}", ch, len(base)))
        for o, (g, l) in ch.items():
            total[o][0] += g
            total[o][1] += l
    if len(argv) > 2:
        print(line("all pairs", {o: tuple(v) for o, v in total.items()}, episodes))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
