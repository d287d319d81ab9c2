#!/bin/bash
# The rule's runs (rule.md): the shipped code in a worktree BASE against the change in /work/main,
# two workers each, one side at a time, shipped first.
#   OUT=/tmp/w/wallscrowd ./run.sh /tmp/w/base2 out/ng-4001
set -u
BASE=$1 NG=/work/main/$2
OUT=${OUT:-/tmp/w/wallscrowd}
mkdir -p $OUT
side() {  # side NAME DIR ARGS...
  local name=$1 dir=$2; shift 2
  [ -f $OUT/$name.json ] || (cd $dir && PYTHONPATH=$dir /work/main/.venv/bin/python -m gpcnav evaluate "$@" \
     --controller nn --workers 2 --out $OUT/$name.json > $OUT/$name.log 2>&1)
}
pair() {  # pair NAME ARGS...
  local name=$1; shift
  side shipped-$name $BASE "$@"; side change-$name /work/main "$@"
}
pair ng $(ls $NG/*.toml)
for s in corridor doorway corner; do pair $s --suite $s --count 200 --seed 91; done
for s in corridor doorway corner; do pair $s-12 --suite $s --movers 12 --count 100 --seed 91; done
echo done > $OUT/DONE
