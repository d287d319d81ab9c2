#!/bin/bash
# The tables of record run again after the filter's change (seed 1, improved), GPC and the
# deployed network, two workers, one run at a time:
#   OUT=docs/data/pedestrians/sets_off/records ./run.sh out/ng-corridor
set -u
NG=$1 OUT=${OUT:-docs/data/pedestrians/sets_off/records}
ev() {  # ev NAME CONTROLLER ARGS...
  local name=$1 ctl=$2; shift 2
  [ -f $OUT/$ctl-$name.json ] || gpcnav evaluate "$@" --controller $ctl --workers 2 --out $OUT/$ctl-$name.json \
    > $OUT/$ctl-$name.log 2>&1
}
for c in gpc nn; do
  ev ucy-orca-40 $c --suite ucy --behaviour orca --count 40 --seed 1
  for s in corridor doorway corner; do ev $s $c --suite $s --count 200 --seed 1; done
  ev ng $c $(ls $NG/*.toml)
done
for c in gpc nn; do
  ev ucy-replay-40 $c --suite ucy --count 40 --seed 1
  ev sq20 $c --suite square-crossing --movers 20 --behaviour orca --count 200 --seed 1
  ev sq30 $c --suite square-crossing --movers 30 --behaviour orca --count 200 --seed 1
  ev ucy-orca-452 $c --suite ucy --behaviour orca --count 452 --seed 1
  ev ucy-replay-452 $c --suite ucy --count 452 --seed 1
done
echo done > $OUT/DONE
