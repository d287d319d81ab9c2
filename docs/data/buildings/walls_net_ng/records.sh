#!/usr/bin/env bash
# the network's tables of record with the walls network adopted by rule4.md (seed 1; navground's 199 files)
set -euo pipefail
cd "$(dirname "$0")/../../../.."
R=docs/data/buildings/walls_net_ng/records
for s in corridor doorway corner; do
  gpcnav evaluate --suite $s --count 200 --seed 1 --controller nn --workers 2 --out $R/nn-$s-s1.json > /dev/null
done
gpcnav evaluate out/ng-corridor/*.toml --controller nn --workers 2 --out $R/nn-ng199.json > /dev/null
echo done
