#!/bin/bash
# The rule's runs (rule.md). Usage: bash run.sh OUTDIR   (from the repository root)
set -e
out=$1; mkdir -p $out/option $out/shipped
ev() {  # ev NAME ARGS...
  local name=$1; shift
  [ -f $out/option/$name.json ] || gpcnav evaluate "$@" --controller gpc --workers 2 --set cold_start_gap=1 \
    --out $out/option/$name.json | tail -1
}
ev held-out-reactive $(ls out/held2/reactive/*/*.toml)
[ -f $out/shipped/held-out-reactive.json ] || gpcnav evaluate $(ls out/held2/reactive/*/*.toml) --controller gpc \
  --workers 2 --out $out/shipped/held-out-reactive.json | tail -1
ev ucy-reactive --suite ucy --behaviour orca --count 40 --seed 5
ev navground-corridor out/ng-1701/*.toml
ev ucy-replay --suite ucy --count 40 --seed 5
ev sq20 --suite square-crossing --movers 20 --count 200 --seed 17
for s in corridor doorway corner; do ev $s --suite $s --count 200 --seed 17; done
