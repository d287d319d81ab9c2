#!/bin/bash
# The rule's runs (rule.md), both sides. Usage: bash run.sh OUTDIR   (from the repository root;
# navground's files exported first: python tools/export_navground_scenario.py --scene corridor --out out/ng-2001 --count 200 --seed 2001)
set -e
out=$1; mkdir -p $out
for side in shipped option; do
  extra=""; [ $side = option ] && extra="--set cold_start_gap=1"
  [ -f $out/$side/navground/SUMMARY.json ] || python tools/noise_repeats.py out/ng-2001/*.toml --out $out/$side/navground \
    --repeats 2 -- --controller gpc --workers 2 $extra | tail -3
  for s in corridor doorway corner; do
    [ -f $out/$side/$s.json ] || gpcnav evaluate --suite $s --count 200 --seed 41 --controller gpc --workers 2 $extra \
      --out $out/$side/$s.json | tail -1
  done
  [ -f $out/$side/sq20.json ] || gpcnav evaluate --suite square-crossing --movers 20 --count 200 --seed 41 --controller gpc \
    --workers 2 $extra --out $out/$side/sq20.json | tail -1
  [ -f $out/$side/ucy-replay.json ] || gpcnav evaluate --suite ucy --count 40 --seed 41 --controller gpc --workers 2 $extra \
    --out $out/$side/ucy-replay.json | tail -1
  [ -f $out/$side/ucy-reactive.json ] || gpcnav evaluate --suite ucy --behaviour orca --count 40 --seed 41 --controller gpc \
    --workers 2 $extra --out $out/$side/ucy-reactive.json | tail -1
done
