"""The shipped GPC on navground's Corridor files 1701-1800 twice: with the files' own sensor seed
(docs/data/pedestrians/passing/shipped/navground-corridor.json) and with only that seed changed
(`seed = S` -> `seed = 9S` under [sensing]; the people and walls the same, the measurement noise
drawn again): how many episodes change outcome; and the day's three options against the first.

    for f in out/ng-1701/*.toml; do sed 's/^seed = \\([0-9]*\\)$/seed = 9\\1/' $f > noise/$(basename $f); done
    gpcnav evaluate noise/*.toml --controller gpc --workers 1 --out EVAL-gpc-1701-1800-noise-seed-9xxxx.json
    python compare.py   (from this folder)
"""
import json

P = "../../pedestrians"


def outcomes(path):
    return {e["scenario"]: e["outcome"] for e in json.load(open(path))["episodes_detail"]}


a = outcomes(f"{P}/passing/shipped/navground-corridor.json")
for name, path in (("the same GPC, other sensor noise", "EVAL-gpc-1701-1800-noise-seed-9xxxx.json"),
                   ("plans trusted for 1.5 s", f"{P}/trust_time/option/navground-corridor.json"),
                   ("a cold start every other tick", f"{P}/cold_start_gap_rule/option/navground-corridor.json"),
                   ("two cold starts a tick", f"{P}/two_cold_starts/option/navground-corridor.json")):
    b = outcomes(path)
    assert set(a) == set(b)
    reached = sum(v == "reached_goal" for v in b.values())
    lost = sum(a[k] == "reached_goal" and b[k] != "reached_goal" for k in a)
    gained = sum(a[k] != "reached_goal" and b[k] == "reached_goal" for k in a)
    print(f"{name}: {reached} of 100 reached (the shipped run: {sum(v == 'reached_goal' for v in a.values())}); "
          f"{lost} goals lost and {gained} gained, episode by episode")
