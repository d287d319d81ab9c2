#!/bin/bash
# The rule's runs (rule.md): the option on every set, then the shipped GPC again on UCY reactive seed 5.
# Usage: bash run.sh OUTDIR   (from the repository root)
set -e
out=$1; mkdir -p $out/option $out/shipped
HERE=$(cd "$(dirname "$0")" && pwd)
ev() {  # ev NAME ARGS...
  local name=$1; shift
  [ -f $out/option/$name.json ] || PYTHONPATH="$HERE" GPCNAV_EXP_TRUST=1.5 gpcnav evaluate "$@" --controller gpc \
    --workers 2 --out $out/option/$name.json | tail -1
}
ev ucy-reactive --suite ucy --behaviour orca --count 40 --seed 5
[ -f $out/shipped/ucy-reactive.json ] || gpcnav evaluate --suite ucy --behaviour orca --count 40 --seed 5 \
  --controller gpc --workers 2 --out $out/shipped/ucy-reactive.json | tail -1
ev held-out-reactive $(ls out/held2/reactive/*/*.toml)
ev navground-corridor out/ng-1701/*.toml
ev ucy-replay --suite ucy --count 40 --seed 5
for s in corridor doorway corner; do ev $s --suite $s --count 200 --seed 17; done
ev sq20 --suite square-crossing --movers 20 --count 200 --seed 17
