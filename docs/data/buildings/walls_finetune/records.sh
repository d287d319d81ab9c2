#!/usr/bin/env bash
# records.sh TREE: once rule4.md adopted c5, the network's tables of record on seed 1 run again with it (TREE: a
# worktree of the adoption commit, run there so that its packages are imported), documents into records/; and two
# sets without walls that must not change (the walls network answers only within 4 m of a wall). After
#   python tools/export_navground_scenario.py --scene corridor --out out/ng-corridor --count 200 --seed 1
set -euo pipefail
T=$1 R=$PWD/docs/data/buildings/walls_finetune/records NG=("$PWD"/out/ng-corridor/*.toml)
mkdir -p "$R"
ev() { (cd "$T" && python -m gpcnav evaluate "$@" --controller nn --workers 2 | tail -1); }
for s in corridor doorway corner; do ev --suite $s --count 200 --seed 1 --out "$R/$s.json"; done
ev "${NG[@]}" --out "$R/ng.json"
ev --suite circle-crossing --movers 10 --count 200 --seed 1 --out "$R/circle10.json"
ev --suite ucy --count 40 --seed 1 --out "$R/ucy40.json"
