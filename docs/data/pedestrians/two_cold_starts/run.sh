#!/bin/bash
# The rule's runs (rule.md). Usage: bash run.sh OUTDIR   (from the repository root)
set -e
out=$1; mkdir -p $out/option $out/shipped
ev() {  # ev NAME ARGS...
  local name=$1; shift
  [ -f $out/option/$name.json ] || gpcnav evaluate "$@" --controller gpc --workers 2 --set cold_starts=2 \
    --out $out/option/$name.json | tail -1
}
ev navground-corridor out/ng-1701/*.toml
ev held-out-reactive $(ls out/held2/reactive/*/*.toml)
ev ucy-reactive --suite ucy --behaviour orca --count 40 --seed 5
ev ucy-replay --suite ucy --count 40 --seed 5
ev sq20 --suite square-crossing --movers 20 --count 200 --seed 17
for s in corridor doorway corner; do ev $s --suite $s --count 200 --seed 17; done
# criterion 4: one worker, back to back
[ -f $out/shipped/held-out-reactive-1w.json ] || gpcnav evaluate $(ls out/held2/reactive/*/*.toml) --controller gpc \
  --workers 1 --out $out/shipped/held-out-reactive-1w.json | tail -1
[ -f $out/option/held-out-reactive-1w.json ] || gpcnav evaluate $(ls out/held2/reactive/*/*.toml) --controller gpc \
  --workers 1 --set cold_starts=2 --out $out/option/held-out-reactive-1w.json | tail -1
