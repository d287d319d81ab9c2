#!/bin/bash
# The second rule's runs (rule2.md): the shipped code in /work/main, B in a worktree /tmp/wt-b.
set -u
OUT=${OUT:-/tmp/wq2}
mkdir -p $OUT
side() {  # side NAME DIR ARGS...
  local name=$1 dir=$2; shift 2
  (cd $dir && PYTHONPATH=$dir /work/main/.venv/bin/python -m gpcnav evaluate "$@" --controller gpc --workers 2 \
     --out $OUT/$name.json > $OUT/$name.log 2>&1)
}
for s in corridor doorway corner; do
  side shipped-$s /work/main --suite $s --count 200 --seed 505
  side change-$s /tmp/wt-b --suite $s --count 200 --seed 505
done
side change-nearwall /tmp/wt-b $(ls /work/main/out/nearwall-505/*.toml)
side shipped-nearwall /work/main $(ls /work/main/out/nearwall-505/*.toml)
side shipped-ng /work/main $(ls /work/main/out/ng-2601/*.toml)
side change-ng /tmp/wt-b $(ls /work/main/out/ng-2601/*.toml)
echo done > $OUT/DONE
