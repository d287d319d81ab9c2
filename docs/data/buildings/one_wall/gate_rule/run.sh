#!/bin/bash
# run.sh TAG [X]: the rule's sets with the walls network gate X (none: as shipped)
tag=$1; export PYTHONPATH=/tmp/rule/sc
[ -n "$2" ] && export GPCNAV_EXP_WALLS_NEAR_M=$2
mkdir -p /tmp/rule/$tag
for s in corridor doorway corner; do
  gpcnav evaluate --suite $s --count 200 --seed 76 --controller nn --workers 2 --out /tmp/rule/$tag/$s.json 2>&1 | tail -1 | cut -c1-110
done
gpcnav evaluate /tmp/rule/ng/*.toml --controller nn --workers 2 --out /tmp/rule/$tag/ng.json 2>&1 | tail -1 | cut -c1-110
gpcnav evaluate /tmp/rule/sw/*.toml --controller nn --workers 2 --out /tmp/rule/$tag/sw.json 2>&1 | tail -1 | cut -c1-110
