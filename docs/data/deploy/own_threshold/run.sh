#!/bin/bash
# The rule's runs (rule.md): the shipped code in a worktree BASE against the change in /work/main,
# two workers each, one side at a time, shipped first.
#   OUT=/tmp/w/own ./run.sh /tmp/w/base3 out/fast out/ng-5001
set -u
BASE=$1 CASES=/work/main/$2 NG=/work/main/$3
OUT=${OUT:-/tmp/w/own}
HERE=$(cd "$(dirname "$0")" && pwd)
mkdir -p $OUT
side() {  # side NAME DIR CONTROLLER ARGS...
  local name=$1 dir=$2 ctl=$3; shift 3
  [ -f $OUT/$name.json ] || (cd $dir && PYTHONPATH=$dir /work/main/.venv/bin/python -m gpcnav evaluate "$@" \
     --controller $ctl --workers 2 --out $OUT/$name.json > $OUT/$name.log 2>&1)
}
pair() {  # pair NAME CONTROLLER ARGS...
  local name=$1 ctl=$2; shift 2
  side shipped-$ctl-$name $BASE $ctl "$@"; side change-$ctl-$name /work/main $ctl "$@"
}
files() {  # files KIND: the students001 cases (a reactive case's file name ends -orca.toml)
  local sfx=; [ $1 = reactive ] && sfx=-orca
  sed "s|^|$CASES/unseen-$1/|; s|\.toml\$|$sfx.toml|" $HERE/students001-cases.txt
}
for c in gpc nn; do
  pair ucy-replay $c --suite ucy --count 80 --seed 81
  pair ucy-orca $c --suite ucy --behaviour orca --count 80 --seed 81
  pair s001-replay $c $(files replay)
  pair s001-reactive $c $(files reactive)
  for s in corridor doorway corner; do pair $s $c --suite $s --count 100 --seed 81; done
  pair sq20 $c --suite square-crossing --movers 20 --behaviour orca --count 100 --seed 81
  pair cc10 $c --suite circle-crossing --movers 10 --behaviour orca --count 100 --seed 81
  pair ng $c $(ls $NG/*.toml)
done
echo done > $OUT/DONE
