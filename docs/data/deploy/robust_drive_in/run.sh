#!/bin/bash
# the runs of rule.md: the GPC's check with robust_drive_in (R), and with the searched way out
# in two phases too (RT), on seeds 4 and 5; the shipped check's runs are two_phase/gpc_seeds45/base-*
. .venv/bin/activate
D=docs/data/deploy/robust_drive_in
mkdir -p out/rdi
for form in R RT; do
for seed in 4 5; do
for spec in "sq30 --suite square-crossing --movers 30 --count 200" "corner --suite corner --count 200" \
            "corridor --suite corridor --count 200" "sq20 --suite square-crossing --movers 20 --count 200" \
            "doorway --suite doorway --count 200" "ucy --suite ucy --count 40" "ucyr --suite ucy --count 40 --behaviour orca"; do
  set -- $spec; name=$1; shift 1
  PYTHONPATH=$D GPCNAV_EXP_ROBUST=$form gpcnav evaluate "$@" --seed $seed --controller gpc --workers 2 --out out/rdi/$form-s$seed-$name.json > out/rdi/$form-s$seed-$name.log 2>&1
  echo "$form s$seed $name $(date +%T)"
done
done
done
