#!/bin/bash
# The README's recorded-people and navground rows run again after the change (seed 1, improved),
# the GPC and the deployed network, two workers, one run at a time:
#   OUT=docs/data/deploy/own_threshold/records ./run.sh out/ng-corridor
set -u
NG=$1 OUT=${OUT:-docs/data/deploy/own_threshold/records}
ev() {  # ev NAME CONTROLLER ARGS...
  local name=$1 ctl=$2; shift 2
  [ -f $OUT/$ctl-$name.json ] || gpcnav evaluate "$@" --controller $ctl --workers 2 --out $OUT/$ctl-$name.json \
    > $OUT/$ctl-$name.log 2>&1
}
for c in gpc nn; do
  ev ucy-orca-40 $c --suite ucy --behaviour orca --count 40 --seed 1
  ev ucy-replay-40 $c --suite ucy --count 40 --seed 1
done
for c in gpc nn; do
  for s in corridor doorway corner; do ev $s $c --suite $s --count 200 --seed 1; done
  ev ng $c $(ls $NG/*.toml)
  ev ucy-orca-452 $c --suite ucy --behaviour orca --count 452 --seed 1
  ev ucy-replay-452 $c --suite ucy --count 452 --seed 1
done
echo done > $OUT/DONE
