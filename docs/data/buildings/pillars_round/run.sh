#!/usr/bin/env bash
# run.sh NAME: rule.md's cases with the walls network now in nn_export/models/improved-walls.onnx of the
# checkout this script is in (the shipped one, or the candidate copied into another checkout), documents
# runs/NAME-*.json: the three suites with a pillar at seed 404 (../pillars/pillars.py), the three suites at
# seed 42, navground's corridor from its seeds 6701-6800 (files in $NG, default out/walls2/ng-6701)
set -euo pipefail
cd "$(dirname "$0")/../../../.."
R=${R:-docs/data/buildings/pillars_round/runs}
NG=${NG:-out/walls2/ng-6701}
mkdir -p "$R"
for s in corridor doorway corner; do
  python docs/data/buildings/pillars/pillars.py $s 60 404 nn "$R/$1-pillar-$s-s404.json" > "$R/$1-pillar-$s-s404.log"
done
for s in corridor doorway corner; do
  gpcnav evaluate --suite $s --count 200 --seed 42 --controller nn --workers 2 --out "$R/$1-$s-s42.json" > /dev/null
done
gpcnav evaluate "$NG"/*.toml --controller nn --workers 2 --out "$R/$1-ng6701.json" > /dev/null
echo done "$1"
