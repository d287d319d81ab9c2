"""The rule's table (rule.md) from the runs: ``python table.py [NAME ...]`` (default E P)."""
import json
import sys
from pathlib import Path

RUNS = Path(__file__).resolve().parent / "runs"
CASES = [("pillar-corridor-s404", "corridor with a pillar, seed 404 (60)"), ("pillar-doorway-s404", "doorway with a pillar (60)"),
         ("pillar-corner-s404", "corner with a pillar (60)"), ("corridor-s42", "corridor, seed 42 (200)"),
         ("doorway-s42", "doorway, seed 42 (200)"), ("corner-s42", "corner, seed 42 (200)"),
         ("ng6701", "navground's Corridor, 6701-6800 (100)")]


def outcomes(path: Path) -> dict:
    d = json.loads(path.read_text())
    if "episodes" in d and isinstance(d["episodes"], list):  # pillars.py
        eps = [(e["outcome"], e.get("collision") or {}) for e in d["episodes"]]
    else:  # EVAL.json
        eps = [(e["outcome"], e.get("collision") or {}) for e in d["episodes_detail"]]
    out = {"reached": 0, "collided": 0, "approaching": 0, "timed_out": 0, "per": [o for o, _ in eps]}
    for o, c in eps:
        out["reached" if o == "reached_goal" else o] += 1
        if o == "collided" and (c.get("robot_speed_towards_mps") or 0.0) > 0.05:
            out["approaching"] += 1
    return out


def main(names):
    rows, total = [], {n: {"reached": 0, "collided": 0, "approaching": 0, "timed_out": 0} for n in names}
    pill = {n: 0 for n in names}
    print("| case | " + " | ".join(names) + " |\n|---|" + "---|" * len(names))
    for key, label in CASES:
        cells = []
        for n in names:
            p = RUNS / f"{n}-{key}.json"
            if not p.is_file():
                cells.append("(not run)")
                continue
            o = outcomes(p)
            for k in total[n]:
                total[n][k] += o[k]
            if key.startswith("pillar"):
                pill[n] += o["reached"]
            cells.append(f"{o['reached']} / {o['collided']} ({o['approaching']}) / {o['timed_out']}")
        print(f"| {label} | " + " | ".join(cells) + " |")
    print("| **all** | " + " | ".join(f"{t['reached']} / {t['collided']} ({t['approaching']}) / {t['timed_out']}"
                                     for t in total.values()) + " |")
    print("\nreached / collided (robot approaching) / timed out; goals with a pillar: "
          + ", ".join(f"{n} {pill[n]}" for n in names))


if __name__ == "__main__":
    main(sys.argv[1:] or ["E", "P"])
