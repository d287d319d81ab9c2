#!/bin/bash
# The rule's runs (rule.md): the shipped GPC and the option on cases never run.
# Usage: bash run.sh OUTDIR [--set passing_samples=2]
set -e
out=$1; shift
mkdir -p $out
for s in corridor doorway corner; do
  gpcnav evaluate --suite $s --count 200 --seed 17 --controller gpc --workers 2 "$@" --out $out/$s.json | tail -1
done
gpcnav evaluate --suite square-crossing --movers 20 --count 200 --seed 17 --controller gpc --workers 2 "$@" --out $out/sq20.json | tail -1
gpcnav evaluate --suite ucy --count 40 --seed 5 --controller gpc --workers 2 "$@" --out $out/ucy-replay.json | tail -1
gpcnav evaluate --suite ucy --behaviour orca --count 40 --seed 5 --controller gpc --workers 2 "$@" --out $out/ucy-reactive.json | tail -1
gpcnav evaluate out/ng-1701/*.toml --controller gpc --workers 2 "$@" --out $out/navground-corridor.json | tail -1
