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
from pathlib import Path
import sys

from scipy.stats import fisher_exact

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))
from gpcnav.navground_twin import clopper_pearson  # noqa: E402


def _counts(outcomes: list[str]) -> tuple[int, int, int]:
    return len(outcomes), outcomes.count("reached_goal"), outcomes.count("collided")


def _cell(k: int, n: int) -> str:
    lo, hi = clopper_pearson(k, n)
    return f"{k} ({100 * lo:.1f}-{100 * hi:.1f} %)"


def _refuse(message: str):
    print(f"twin_table.py: error: {message}", file=sys.stderr)
    raise SystemExit(2)


def _document(path: str, key: str) -> dict:
    """The JSON document at ``path`` holding ``key``; a one-line exit naming it otherwise."""
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        _refuse(f"{path}: cannot read it ({type(exc).__name__}: {exc})")
    if not isinstance(doc, dict) or key not in doc:
        _refuse(f"{path}: not the document expected (no {key!r})")
    return doc


def row(label: str, eval_path: str, twin_path: str) -> str:
    ev = _document(eval_path, "episodes_detail")  # gpcnav evaluate's EVAL.json
    tw = _document(twin_path, "episodes")  # python -m gpcnav.navground_twin --out
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
    rows = [row(*argv[i:i + 3]) for i in range(0, len(argv), 3)]  # every file read before anything is printed
    print("| scene, behaviour | episodes | gpcnav: reached (95 % CP) | navground: reached (95 % CP) | Fisher p | "
          "gpcnav: collided (95 % CP) | navground: collided (95 % CP) | Fisher p | collided in both |")
    print("|---|---|---|---|---|---|---|---|---|")
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
