#!/usr/bin/env bash
# judge.sh TREE NAME [3]: rule.md's cases (or, with 3, rule3.md's) with the walls network of the work tree TREE
# (run there, so that its packages are the ones imported), documents into
# docs/data/buildings/walls_finetune/runs/NAME-*.json (runs3/). From the repository root, after
#   python docs/data/buildings/walls_finetune/scenes.py out/wf/judge/open 8301 60          (8302: judge3)
#   python docs/data/buildings/one_wall/gen.py out/wf/judge/onewall 11                      (12)
#   python tools/export_navground_scenario.py --scene corridor --out out/wf/judge/navground --count 100 --seed 7341 (7441)
set -euo pipefail
T=$1 N=$2
if [ "${3:-}" = 3 ]; then J=$PWD/out/wf/judge3 R=$PWD/docs/data/buildings/walls_finetune/runs3 S=83
else J=$PWD/out/wf/judge R=$PWD/docs/data/buildings/walls_finetune/runs S=82; fi
mkdir -p "$R"
ev() { (cd "$T" && python -m gpcnav evaluate "$@" --controller nn --workers 2 | tail -1); }
ev "$J"/open/*.toml --out "$R/$N-open.json"
ev "$J"/onewall/*.toml --out "$R/$N-onewall.json"
for s in corridor doorway corner; do ev --suite $s --count 200 --seed $S --out "$R/$N-$s-s$S.json"; done
ev "$J"/navground/*.toml --out "$R/$N-navground.json"
