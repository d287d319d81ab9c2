"""Two runs of the same episodes, compared episode by episode (``scenarios.paired``): for
reaching the goal and for colliding, how many episodes gained the outcome and how many lost
it, and the exact two-sided sign test of that split; over several pairs, the sums too.

Usage::

    python tools/paired.py BASE.json NEW.json [BASE2.json NEW2.json ...]

Each file an EVAL.json of ``gpcnav evaluate``, the two of a pair on the same episodes in the
same order: the same suite with the same seed and settings, or both scenario files (anything
else is refused in one line, exit 2; ``scenarios.paired.run_changes``). ``gpcnav compare``
puts the same numbers under its table, against its first controller. docs/evaluation.md,
"Two runs of the same episodes, compared".
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from scenarios.paired import PAIRED_OUTCOMES, run_changes, sign_test  # noqa: E402


def line(label: str, changes: dict[str, tuple[int, int]], n: int) -> str:
    parts = [f"{o}: +{g} -{l} (p = {sign_test(g, l):.3g})" for o, (g, l) in changes.items()]
    return f"{label} ({n} episodes): " + "; ".join(parts)


def main(argv: list[str]) -> int:
    if len(argv) < 2 or len(argv) % 2:
        print("usage: python tools/paired.py BASE.json NEW.json [BASE2.json NEW2.json ...]", file=sys.stderr)
        return 2
    total = {o: [0, 0] for o in PAIRED_OUTCOMES}
    episodes = 0
    for a, b in zip(argv[::2], argv[1::2]):
        try:
            base, new = (json.loads(Path(p).read_text()) for p in (a, b))
            changes = run_changes(base, new)
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            print(f"{a} / {b}: {type(exc).__name__}: {exc}", file=sys.stderr)
            return 2
        n = len(base["episodes_detail"])
        episodes += n
        print(line(f"{Path(a).name} -> {Path(b).name}", changes, n))
        for o, (g, l) in changes.items():
            total[o][0] += g
            total[o][1] += l
    if len(argv) > 2:
        print(line("all pairs", {o: tuple(v) for o, v in total.items()}, episodes))
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
