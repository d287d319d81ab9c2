#!/bin/bash
# the adopted GPC check on cases it never saw: development seed 6, the seven suites, against the
# check before (GPCNAV_EXP_ROBUST=OFF), both run now
. .venv/bin/activate
D=docs/data/deploy/robust_drive_in
mkdir -p out/rdi6
for spec in "sq30 --suite square-crossing --movers 30 --count 200" "sq20 --suite square-crossing --movers 20 --count 200" \
            "corridor --suite corridor --count 200" "doorway --suite doorway --count 200" "corner --suite corner --count 200" \
            "ucy --suite ucy --count 40" "ucyr --suite ucy --count 40 --behaviour orca"; do
  set -- $spec; name=$1; shift 1
  gpcnav evaluate "$@" --seed 6 --controller gpc --workers 2 --out out/rdi6/new-s6-$name.json > out/rdi6/new-s6-$name.log 2>&1
  PYTHONPATH=$D GPCNAV_EXP_ROBUST=OFF gpcnav evaluate "$@" --seed 6 --controller gpc --workers 2 --out out/rdi6/before-s6-$name.json > out/rdi6/before-s6-$name.log 2>&1
  echo "s6 $name $(date +%T)"
done
