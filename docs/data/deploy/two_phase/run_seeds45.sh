#!/bin/bash
. .venv/bin/activate
D=docs/data/deploy/two_phase
mkdir -p out/gtp45
for seed in 4 5; do
for spec in "sq30 --suite square-crossing --movers 30 --count 200" "corner --suite corner --count 200" \
            "corridor --suite corridor --count 200" "sq20 --suite square-crossing --movers 20 --count 200" \
            "doorway --suite doorway --count 200" "ucy --suite ucy --count 40" "ucyr --suite ucy --count 40 --behaviour orca"; do
  set -- $spec; name=$1; shift 1
  gpcnav evaluate "$@" --seed $seed --controller gpc --workers 2 --out out/gtp45/base-s$seed-$name.json > out/gtp45/base-s$seed-$name.log 2>&1
  PYTHONPATH=$D GPCNAV_EXP_GPC_TWO_PHASE=1 gpcnav evaluate "$@" --seed $seed --controller gpc --workers 2 --out out/gtp45/two-s$seed-$name.json > out/gtp45/two-s$seed-$name.log 2>&1
  echo "s$seed $name $(date +%T)"
done
done
