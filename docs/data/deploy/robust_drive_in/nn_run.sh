#!/bin/bash
. .venv/bin/activate
D=docs/data/deploy/robust_drive_in
mkdir -p out/rdinn
for seed in 4 5; do
for spec in "sq30 --suite square-crossing --movers 30 --count 200" "corner --suite corner --count 200" \
            "corridor --suite corridor --count 200" "sq20 --suite square-crossing --movers 20 --count 200" \
            "doorway --suite doorway --count 200" "ucy --suite ucy --count 40" "ucyr --suite ucy --count 40 --behaviour orca"; do
  set -- $spec; name=$1; shift 1
  gpcnav evaluate "$@" --seed $seed --controller nn --workers 2 --out out/rdinn/base-s$seed-$name.json > out/rdinn/base-s$seed-$name.log 2>&1
  PYTHONPATH=$D GPCNAV_EXP_NN_ROBUST=1 gpcnav evaluate "$@" --seed $seed --controller nn --workers 2 --out out/rdinn/robust-s$seed-$name.json > out/rdinn/robust-s$seed-$name.log 2>&1
  echo "s$seed $name $(date +%T)"
done
done
