#!/bin/bash
# The rule's runs (rule.md): the shipped code in /work/main (HEAD), the change in a worktree
# /tmp/wt-new (HEAD + the one line); two workers each, one side at a time.
set -u
OUT=${OUT:-/tmp/wq}
mkdir -p $OUT
side() {  # side NAME DIR ARGS...
  local name=$1 dir=$2; shift 2
  (cd $dir && PYTHONPATH=$dir /work/main/.venv/bin/python -m gpcnav evaluate "$@" --controller gpc --workers 2 \
     --out $OUT/$name.json > $OUT/$name.log 2>&1)
}
for s in corridor doorway corner; do
  side shipped-$s /work/main --suite $s --count 200 --seed 404
  side change-$s /tmp/wt-new --suite $s --count 200 --seed 404
done
side change-ng /tmp/wt-new $(ls /work/main/out/ng-2401/*.toml)
side shipped-ng /work/main $(ls /work/main/out/ng-2401/*.toml)
side shipped-nearwall /work/main $(ls /work/main/out/nearwall-404/*.toml)
side change-nearwall /tmp/wt-new $(ls /work/main/out/nearwall-404/*.toml)
echo done > $OUT/DONE
