"""Where the deployed walls network's command fails its check, would the GPC's? A study.

The network behind its planner-free check drives each scenario file, as `gpcnav evaluate
--controller nn` makes it; beside it the GPC behind its own check (as `--controller gpc`
makes it) is asked every decision in the same observation, and its answer thrown away (a
shadow: it plans from the state the network drove to, keeping its own filters and warm start).
Per decision: whether the check replaced the network's command (a fallback: the network has no
alternatives) and whether the GPC's check had to go past the GPC's own plan and alternatives
to a manoeuvre (its fallback). The four counts tell the states where the network is stopped
and the GPC, checked as it is, is not, from those where both are. The two checks differ (the
GPC's plans trusted for 3 s, the network's roll-out for 4.5 s; the GPC's alternatives; near
walls the GPC's smaller margin), so the first count is not the network's answers alone.

The run recorded in output.txt, from the repository's root (navground seeds 24001-24020, seen in
the training of rule5.md's candidate; exported by ``python tools/export_navground_scenario.py
--scene corridor --out out/walls2/ng-24001 --count 100 --seed 24001``):

    python docs/data/buildings/walls_net_ng/shadow/shadow.py $(ls out/walls2/ng-24001/*.toml | head -20) \
        > docs/data/buildings/walls_net_ng/shadow/output.txt
"""
from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[5]))

from casadi_gpc.config import preset  # noqa: E402
from gpcnav.commands.common import for_run  # noqa: E402
from gpcnav.controllers import ControllerSpec, make  # noqa: E402
from scenarios import load_scenario  # noqa: E402
from scenarios.simulator import simulate  # noqa: E402


def episode(path: Path):
    scenario = load_scenario(path)
    config = for_run(preset("improved"), [scenario])
    nn = make(ControllerSpec("nn"), config, scenario.robot)
    gpc = make(ControllerSpec("gpc"), config, scenario.robot)
    pairs = []

    class Both:  # the network drives; the GPC answers the same observation, unheard
        sample_time_s = nn.sample_time_s

        def __getattr__(self, name):
            return getattr(nn, name)

        def reset(self):
            nn.reset()
            gpc.reset()

        def decide(self, obs):
            d = nn.decide(obs)
            g = gpc.decide(obs)
            pairs.append((bool(d.fallback), bool(g.fallback)))
            return d

    log = simulate(scenario, Both(), "nn+gpc-shadow")
    return log.outcome, pairs


def main() -> None:
    total, outcomes = Counter(), Counter()
    for p in map(Path, sys.argv[1:]):
        outcome, pairs = episode(p)
        c = Counter(pairs)
        outcomes[outcome] += 1
        total.update(c)
        print(f"{p.name}: {outcome}, {len(pairs)} decisions; network replaced {c[(True, False)] + c[(True, True)]}, "
              f"of them the GPC's answer too {c[(True, True)]}; the GPC's alone {c[(False, True)]}", flush=True)
    n = sum(total.values())
    nn_rep = total[(True, False)] + total[(True, True)]
    print(f"\n{len(sys.argv) - 1} files, outcomes of the network behind its check: {dict(outcomes)}")
    print(f"{n} decisions: the network's command replaced by its check in {nn_rep} ({nn_rep / n:.1%});")
    print(f"  in {total[(True, True)]} of those the GPC's answer in the same observation was replaced too "
          f"({total[(True, True)] / max(nn_rep, 1):.1%} of them), in {total[(True, False)]} it was not;")
    print(f"  the GPC's alone replaced in {total[(False, True)]}; neither in {total[(False, False)]}.")


if __name__ == "__main__":
    main()
