"""The table of a rule fixed before its runs (``docs/data/*/*/rule.md``): two sides of the same
episodes, the shipped code and a change, set by set, from a run folder of ``gpcnav evaluate``
documents; and the verdict of the rule's conditions. Each rule's ``table.py`` names its sets and
conditions and calls these.

    sides = compare(Path(RUNS), {"gpc": ["corridor", ...], "nn": [...]})
    verdict([("1. collisions ...", ok), ...])
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

from scipy.stats import binomtest

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from scenarios.paired import outcome_changes  # noqa: E402

__all__ = ["compare", "p_lost", "verdict"]

SIDES = ("shipped", "change")


def p_lost(gained: int, lost: int) -> float:
    """One-sided exact sign test: the chance of at least ``lost`` losses among ``gained + lost``
    changed episodes were a change equally likely either way (1.0 when nothing changed)."""
    n = gained + lost
    return float(binomtest(lost, n, 0.5, alternative="greater").pvalue) if n else 1.0


def compare(runs: Path, sets: dict[str, list[str]], first: str = "controller, set",
            file=lambda side, controller, name: f"{side}-{controller}-{name}.json",
            label=lambda controller, name: f"{controller}, {name}", median: bool = True, extra=None) -> dict:
    """Print the Markdown table of ``sets`` (controller -> set names) from ``runs``: per set and
    side reached / collided (robot approaching) / timed out (and the decision median), then
    ``extra`` (``(heading, doc -> text)``, of the change's document) and the goals gained and
    lost episode by episode; a side not run reads "not run". Return per controller the totals:
    ``{side: [collisions, approaching]}``, ``gained``, ``lost``, and ``slower`` (``(set, the
    change's median over the shipped)`` for the sets both sides ran)."""
    ms = ", decision median" if median else ""
    head = [first, f"shipped: reached / collided (approaching) / timed out{ms}", "the change"]
    head += [extra[0]] if extra else []
    head.append("goals gained / lost")
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    tot = {}
    for c, names in sets.items():
        t = tot[c] = {"shipped": [0, 0], "change": [0, 0], "gained": 0, "lost": 0, "slower": []}
        for name in names:
            cells, eps, more = [], {}, ""
            for side in SIDES:
                f = runs / file(side, c, name)
                if not f.is_file():
                    cells.append("not run")
                    continue
                doc = json.loads(f.read_text())
                e = doc["episodes_detail"]
                out = [x["outcome"] for x in e]
                med = doc["compute_time_s"]["median"] * 1e3
                cells.append(f"{out.count('reached_goal')} / {out.count('collided')} ({doc['collided_robot_approaching']}) / "
                             f"{out.count('timed_out')}" + (f", {med:.2f} ms" if median else ""))
                eps[side] = (e, med)
                t[side][0] += out.count("collided")
                t[side][1] += doc["collided_robot_approaching"]
                if extra and side == "change":
                    more = extra[1](doc)
            gl = ""
            if len(eps) == 2:
                g, l = outcome_changes(eps["shipped"][0], eps["change"][0])["reached_goal"]
                t["gained"] += g
                t["lost"] += l
                t["slower"].append((name, eps["change"][1] / eps["shipped"][1]))
                gl = f"+{g} / -{l}"
            print("| " + " | ".join([label(c, name), *cells, *([more] if extra else []), gl]) + " |")
    return tot


def verdict(conditions: list[tuple[str, bool]]) -> bool:
    """Print each condition, whether it holds, and the rule's verdict; whether all hold."""
    print()
    for text, ok in conditions:
        print(f"- {text}: {'holds' if ok else 'FAILS'}")
    adopted = all(ok for _, ok in conditions)
    print(f"\n{'Adopted' if adopted else 'Rejected'} by the rule.")
    return adopted
