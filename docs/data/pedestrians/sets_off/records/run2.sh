#!/bin/bash
# After run.sh: the held-out recordings' 78 cases each way (out/held, made as docs/pedestrians.md,
# "Recordings never used before", says), the crowd suites of the tables of record, and the
# peers on the README's rows, all after the filter's change (seed 1, improved, two workers):
#   OUT=docs/data/pedestrians/sets_off/records ./run2.sh out/held out/ng-corridor
set -u
HELD=$1 NG=$2 OUT=${OUT:-docs/data/pedestrians/sets_off/records}
ev() {  # ev NAME CONTROLLER ARGS...
  local name=$1 ctl=$2; shift 2
  [ -f $OUT/$ctl-$name.json ] || gpcnav evaluate "$@" --controller $ctl --workers 2 --out $OUT/$ctl-$name.json \
    > $OUT/$ctl-$name.log 2>&1
}
cmp() {  # cmp NAME CONTROLLERS ARGS...
  local name=$1 ctls=$2; shift 2
  [ -f $OUT/compare-$name.json ] || gpcnav compare "$@" --controllers $ctls --workers 2 --out $OUT/compare-$name.json \
    > $OUT/compare-$name.log 2>&1
}
cmp held-reactive stand,gpc,nn $(ls $HELD/reactive/*/*.toml)
cmp held-replay stand,gpc,nn $(ls $HELD/replay/*/*.toml)
for c in gpc nn; do
  ev cc5 $c --suite circle-crossing --movers 5 --behaviour orca --count 200 --seed 1
  ev cc10 $c --suite circle-crossing --movers 10 --behaviour orca --count 200 --seed 1
  ev sq5 $c --suite square-crossing --movers 5 --behaviour orca --count 200 --seed 1
  ev random-multi $c --suite random-multi --count 200 --seed 1
done
for s in corridor doorway corner; do cmp $s orca,hrvo,social_force,mppi --suite $s --count 200 --seed 1; done
cmp ucy-replay-40 orca,hrvo,social_force,mppi --suite ucy --count 40 --seed 1
cmp ucy-orca-40 orca,hrvo,social_force,mppi --suite ucy --behaviour orca --count 40 --seed 1
cmp ng orca,hrvo,social_force,mppi $(ls $NG/*.toml)
echo done > $OUT/DONE2
