#!/usr/bin/env bash
# run2.sh NAME: the rule's cases with the walls network now in nn_export/models/improved-walls.onnx
# (the shipped one, or the chosen one copied there), documents in runs2/NAME-*.json (rule2.md)
set -euo pipefail
cd "$(dirname "$0")/../../../.."
R=docs/data/buildings/walls_net_ng/runs2
mkdir -p $R
for s in corridor doorway corner; do
  gpcnav evaluate --suite $s --count 200 --seed 28 --controller nn --workers 2 --out $R/$1-$s-s28.json > /dev/null
done
gpcnav evaluate out/walls2/ng-6101/*.toml --controller nn --workers 2 --out $R/$1-ng6101.json > /dev/null
echo done $1
