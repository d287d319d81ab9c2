#!/usr/bin/env bash
# judge.sh TREE NAME [3|4 [OPTIONS...]]: rule.md's cases (or, with 3 or 4, rule3.md's or rule4.md's) with the walls
# network of the work tree TREE (run there, so that its packages are the ones imported), or the one OPTIONS give
# (`--walls-model FILE`), documents into docs/data/buildings/walls_finetune/runs/NAME-*.json (runs3/, runs4/).
# From the repository root, after
#   python docs/data/buildings/walls_finetune/scenes.py out/wf/judge/open 8301 60      (8302: judge3, 8303: judge4)
#   python docs/data/buildings/one_wall/gen.py out/wf/judge/onewall 11                  (12, 13)
#   python tools/export_navground_scenario.py --scene corridor --out out/wf/judge/navground --count 100 --seed 7341
#                                                                                       (7441, 7541)
set -euo pipefail
T=$1 N=$2
case "${3:-}" in
  3) J=$PWD/out/wf/judge3 R=$PWD/docs/data/buildings/walls_finetune/runs3 S=83 ;;
  4) J=$PWD/out/wf/judge4 R=$PWD/docs/data/buildings/walls_finetune/runs4 S=84 ;;
  *) J=$PWD/out/wf/judge R=$PWD/docs/data/buildings/walls_finetune/runs S=82 ;;
esac
shift $(( $# < 3 ? $# : 3 ))
OPTIONS=("$@")
mkdir -p "$R"
ev() { (cd "$T" && python -m gpcnav evaluate "$@" --controller nn --workers 2 "${OPTIONS[@]}" | tail -1); }
ev "$J"/open/*.toml --out "$R/$N-open.json"
ev "$J"/onewall/*.toml --out "$R/$N-onewall.json"
for s in corridor doorway corner; do ev --suite $s --count 200 --seed $S --out "$R/$N-$s-s$S.json"; done
ev "$J"/navground/*.toml --out "$R/$N-navground.json"
