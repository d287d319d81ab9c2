#!/bin/bash
# bash run.sh OUTDIR   (from the repository root): the rule's runs, both sides, seeds 38 and 39
set -e
out=$1; mkdir -p $out   # the documents of record are in runs/ here
for seed in 38 39; do
  for s in corridor doorway corner; do
    for side in shipped option; do
      extra=""; [ $side = option ] && extra="--set cold_start_gap=1"
      [ -f $out/$s-$seed-$side.json ] || gpcnav evaluate --suite $s --count 200 --seed $seed --controller gpc \
        --workers 2 $extra --out $out/$s-$seed-$side.json | tail -1
    done
  done
done
