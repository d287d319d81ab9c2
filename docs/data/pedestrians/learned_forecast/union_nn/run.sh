#!/usr/bin/env bash
# the rule's runs: run.sh BEFORE_REPO AFTER_REPO OUT (worktrees of the commit before the option and of the option's)
set -u
before=$1; after=$2; out=$3
export PATH=/work/main/.venv/bin:$PATH
mkdir -p "$out"
for side in before after; do
  repo=$before; [ $side = after ] && repo=$after
  for s in corner doorway corridor; do
    PYTHONPATH=$repo gpcnav evaluate --suite $s --count 200 --seed 44 --controller nn --workers 2 \
      --out "$out/$s-44-$side.json" > "$out/$s-44-$side.log" 2>&1
  done
  PYTHONPATH=$repo gpcnav evaluate /work/main/out/lp/ng-6901/*.toml --controller nn --workers 2 \
    --out "$out/ng-6901-$side.json" > "$out/ng-6901-$side.log" 2>&1
done
echo DONE
