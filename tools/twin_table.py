"""One Markdown row per pair: a controller as gpcnav runs it (EVAL.json of ``gpcnav evaluate``)
against the same behaviour inside navground (the JSON of ``python -m gpcnav.navground_twin``),
on the same scenario files.

Each row: reached and collided counts of both, their two-sided 95 % Clopper-Pearson
intervals, and the two-sided p-value of Fisher's exact test of equal collision rates (and of
equal success rates).

Usage::

    python tools/twin_table.py LABEL EVAL.json TWIN.json [LABEL EVAL.json TWIN.json ...]
"""
from __future__ import annotations

import json
import sys

from scipy.stats import fisher_exact

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))
from gpcnav.navground_twin import clopper_pearson  # noqa: E402


def _counts(outcomes: list[str]) -> tuple[int, int, int]:
    return len(outcomes), outcomes.count("reached_goal"), outcomes.count("collided")


def _cell(k: int, n: int) -> str:
    lo, hi = clopper_pearson(k, n)
    return f"{k} ({100 * lo:.1f}-{100 * hi:.1f} %)"


def row(label: str, eval_path: str, twin_path: str) -> str:
    ev = json.load(open(eval_path))
    tw = json.load(open(twin_path))
    a = {e["scenario"]: e["outcome"] for e in ev["episodes_detail"]}
    b = {e["name"]: e["outcome"] for e in tw["episodes"]}
    if set(a) != set(b):
        raise SystemExit(f"{label}: the two runs are not on the same scenarios")
    n, ra, ca = _counts(list(a.values()))
    _, rb, cb = _counts(list(b.values()))
    p_c = fisher_exact([[ca, n - ca], [cb, n - cb]])[1]
    p_r = fisher_exact([[ra, n - ra], [rb, n - rb]])[1]
    both = sum(a[s] == b[s] == "collided" for s in a)
    return (f"| {label} | {n} | {_cell(ra, n)} | {_cell(rb, n)} | {p_r:.2f} | {_cell(ca, n)} | {_cell(cb, n)} | "
            f"{p_c:.2f} | {both} |")


def main(argv: list[str]) -> int:
    if not argv or len(argv) % 3:
        print(__doc__)
        return 2
    print("| scene, behaviour | episodes | gpcnav: reached (95 % CP) | navground: reached (95 % CP) | Fisher p | "
          "gpcnav: collided (95 % CP) | navground: collided (95 % CP) | Fisher p | collided in both |")
    print("|---|---|---|---|---|---|---|---|---|")
    for i in range(0, len(argv), 3):
        print(row(*argv[i:i + 3]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
