#!/usr/bin/env bash
# run.sh NAME: the rule's cases with the walls network now in nn_export/models/improved-walls.onnx
# (the shipped one, or C copied there), documents in runs/NAME-*.json
set -euo pipefail
cd "$(dirname "$0")/../../../.."
R=docs/data/buildings/walls_net_ng/runs
for s in corridor doorway corner; do
  gpcnav evaluate --suite $s --count 200 --seed 27 --controller nn --workers 2 --out $R/$1-$s-s27.json > /dev/null
done
gpcnav evaluate out/walls2/ng-6001/*.toml --controller nn --workers 2 --out $R/$1-ng6001.json > /dev/null
echo done $1
