#!/bin/bash
# The rule's runs (rule.md): the shipped code in a worktree BASE against the change in /work/main,
# two workers each, one side at a time, shipped first.
#   OUT=/tmp/w/setsoff ./run.sh /tmp/w/base out/ng-3001
set -u
BASE=$1 NG=/work/main/$2
OUT=${OUT:-/tmp/w/setsoff}
mkdir -p $OUT
side() {  # side NAME DIR CONTROLLER ARGS...
  local name=$1 dir=$2 ctl=$3; shift 3
  (cd $dir && PYTHONPATH=$dir /work/main/.venv/bin/python -m gpcnav evaluate "$@" --controller $ctl --workers 2 \
     --out $OUT/$name.json > $OUT/$name.log 2>&1)
}
pair() {  # pair NAME CONTROLLER ARGS...
  local name=$1 ctl=$2; shift 2
  side shipped-$ctl-$name $BASE $ctl "$@"; side change-$ctl-$name /work/main $ctl "$@"
}
for c in gpc nn; do
  for s in corridor doorway corner; do pair $s $c --suite $s --count 200 --seed 61; done
  pair cc10 $c --suite circle-crossing --movers 10 --behaviour orca --count 200 --seed 61
  pair ucy-orca $c --suite ucy --behaviour orca --count 80 --seed 61
done
pair sq20 gpc --suite square-crossing --movers 20 --behaviour orca --count 200 --seed 61
pair ucy-replay gpc --suite ucy --count 80 --seed 61
pair ng gpc $(ls $NG/*.toml)
echo done > $OUT/DONE
