#!/usr/bin/env bash
# dev.sh TREE NAME: the development cases of rule.md, with the walls network of the work tree TREE (a
# checkout with the candidate copied to nn_export/models/improved-walls.onnx; run there, so that its
# packages are the ones imported), documents into out/wf/dev/runs/NAME-*.json. Run from the repository
# root after run.sh and
#   python docs/data/buildings/walls_finetune/scenes.py out/wf/dev/open 8201 30
#   python docs/data/buildings/one_wall/gen.py out/wf/dev/onewall 7
set -euo pipefail
T=$1 N=$2 W=$PWD/out/wf/dev
R=$W/runs
mkdir -p "$R"
ev() { (cd "$T" && python -m gpcnav evaluate "$@" --controller nn --workers 2 | tail -1); }
ev "$W"/open/*.toml --out "$R/$N-open.json"
ev "$W"/onewall/*.toml --out "$R/$N-onewall.json"
for s in corridor doorway corner; do ev --suite $s --count 20 --seed 2 --out "$R/$N-$s-s2.json"; done
