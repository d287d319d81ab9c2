#!/usr/bin/env bash
# judge.sh TREE NAME: rule.md's cases with the walls network of the work tree TREE (run there, so that its
# packages are the ones imported), documents into docs/data/buildings/walls_finetune/runs/NAME-*.json. From the
# repository root, after
#   python docs/data/buildings/walls_finetune/scenes.py out/wf/judge/open 8301 60
#   python docs/data/buildings/one_wall/gen.py out/wf/judge/onewall 11
#   python tools/export_navground_scenario.py --scene corridor --out out/wf/judge/navground --count 100 --seed 7341
set -euo pipefail
T=$1 N=$2 J=$PWD/out/wf/judge R=$PWD/docs/data/buildings/walls_finetune/runs
mkdir -p "$R"
ev() { (cd "$T" && python -m gpcnav evaluate "$@" --controller nn --workers 2 | tail -1); }
ev "$J"/open/*.toml --out "$R/$N-open.json"
ev "$J"/onewall/*.toml --out "$R/$N-onewall.json"
for s in corridor doorway corner; do ev --suite $s --count 200 --seed 82 --out "$R/$N-$s-s82.json"; done
ev "$J"/navground/*.toml --out "$R/$N-navground.json"
