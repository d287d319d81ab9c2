#!/bin/bash
# The rules' runs: the shipped code in /work/main against a change in a worktree, two workers
# each, one side at a time, on the three wall suites of SEED, navground's corridor files in
# NG_DIR and the near-wall class in NEAR_DIR.
#   rule.md  (A, worktree /tmp/wt-new):  OUT=/tmp/wq  ./run.sh 404 /tmp/wt-new out/ng-2401 out/nearwall-404
#   rule2.md (B, worktree /tmp/wt-b):    OUT=/tmp/wq2 ./run.sh 505 /tmp/wt-b out/ng-2601 out/nearwall-505 swapped
# The last argument only orders the sides (the first run took the change first on navground's
# files and the shipped code first on the class; the second, the other way round).
set -u
SEED=$1 CHANGE=$2 NG=/work/main/$3 NEAR=/work/main/$4 ORDER=${5:-}
OUT=${OUT:-/tmp/wq}
mkdir -p $OUT
side() {  # side NAME DIR ARGS...
  local name=$1 dir=$2; shift 2
  (cd $dir && PYTHONPATH=$dir /work/main/.venv/bin/python -m gpcnav evaluate "$@" --controller gpc --workers 2 \
     --out $OUT/$name.json > $OUT/$name.log 2>&1)
}
pair() {  # pair NAME FIRST ARGS...: both sides, FIRST (shipped or change) first
  local name=$1 first=$2; shift 2
  if [ $first = shipped ]; then side shipped-$name /work/main "$@"; side change-$name $CHANGE "$@"
  else side change-$name $CHANGE "$@"; side shipped-$name /work/main "$@"; fi
}
for s in corridor doorway corner; do pair $s shipped --suite $s --count 200 --seed $SEED; done
if [ -z "$ORDER" ]; then
  pair ng change $(ls $NG/*.toml); pair nearwall shipped $(ls $NEAR/*.toml)
else
  pair nearwall change $(ls $NEAR/*.toml); pair ng shipped $(ls $NG/*.toml)
fi
echo done > $OUT/DONE
