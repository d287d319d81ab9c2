#!/bin/bash
# The rule's runs (rule.md): the shipped code in a worktree BASE (commit c853f1e) against the
# change in /work/main, two workers each, one side at a time, shipped first.
#   OUT=/tmp/w/fast ./run.sh /tmp/w/base out/fast
# out/fast/unseen-{replay,reactive}/: the held-out recordings' cases not among the 78
# (rule.md, A), made by `gpcnav import-tracks` (every case) less out/held/{replay,reactive}.
set -u
BASE=$1 CASES=/work/main/$2
OUT=${OUT:-/tmp/w/fast}
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
files() {  # files KIND: set A's case files (a reactive case's file name ends -orca.toml)
  local sfx=; [ $1 = reactive ] && sfx=-orca
  ls $CASES/unseen-$1/biwi_eth-*.toml $CASES/unseen-$1/biwi_hotel-*.toml
  sed "s|^|$CASES/unseen-$1/|; s|\.toml\$|$sfx.toml|" $HERE/students001-cases.txt
}
pair held-replay gpc $(files replay)
pair held-reactive gpc $(files reactive)
pair ucy-replay gpc --suite ucy --count 80 --seed 71
pair ucy-orca gpc --suite ucy --behaviour orca --count 80 --seed 71
pair held-reactive nn $(files reactive)
pair ucy-orca nn --suite ucy --behaviour orca --count 80 --seed 71
for s in corridor doorway corner; do pair $s gpc --suite $s --count 100 --seed 71; done
echo done > $OUT/DONE
