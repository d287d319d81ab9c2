#!/usr/bin/env bash
# run.sh NAME [confirm|confirm3|confirm4|confirm5|confirm6]: the rule's cases with the walls network now in
# nn_export/models/improved-walls.onnx (the shipped one, or a candidate copied there), documents
# NAME-*.json: rule.md's cases (seed 27, navground 6001-6100) into runs/; with "confirm", rule2.md's and
# rule4.md's confirmation cases (seed 28, navground 6101-6200) into runs2/; with "confirm3", rule5.md's
# (seed 29, navground 6201-6300) into runs3/; with "confirm4", rule6.md's (seed 30, navground 6301-6400)
# into runs4/; with "confirm5", rule7.md's (seed 31, navground 6401-6500) into runs5/;
# with "confirm6", rule8.md's (seed 32, navground 6501-6600) into runs6/
set -euo pipefail
cd "$(dirname "$0")/../../../.."
case "${2:-}" in
  confirm) R=runs2 S=28 NG=6101 ;;
  confirm3) R=runs3 S=29 NG=6201 ;;
  confirm4) R=runs4 S=30 NG=6301 ;;
  confirm5) R=runs5 S=31 NG=6401 ;;
  confirm6) R=runs6 S=32 NG=6501 ;;
  *) R=runs S=27 NG=6001 ;;
esac
R=docs/data/buildings/walls_net_ng/$R
mkdir -p $R
for s in corridor doorway corner; do
  gpcnav evaluate --suite $s --count 200 --seed $S --controller nn --workers 2 --out $R/$1-$s-s$S.json > /dev/null
done
gpcnav evaluate out/walls2/ng-$NG/*.toml --controller nn --workers 2 --out $R/$1-ng$NG.json > /dev/null
echo done $1
