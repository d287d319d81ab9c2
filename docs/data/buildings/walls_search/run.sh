#!/bin/bash
# the runs of rule.md: the shipped check (base) and W on seed 7 of the three wall suites, then
# navground's Corridor (out/ng-corridor: tools/export_navground_scenario.py --scene corridor
# --count 200 --seed 1, 199 files), then 20 square crossings among 20 walkers (unchanged?)
. .venv/bin/activate
D=docs/data/buildings/walls_search
O=out/ws
mkdir -p $O
for suite in corridor doorway corner; do
  for form in base W; do
    [ $form = W ] && sw=1 || sw=0
    PYTHONPATH=$D GPCNAV_EXP_WALLS_SEARCH=$sw gpcnav evaluate --suite $suite --count 200 --seed 7 --controller gpc \
      --workers 2 --out $O/$form-s7-$suite.json > $O/$form-s7-$suite.log 2>&1
    echo "$form s7 $suite $(date +%T)"
  done
done
for form in W base; do
  [ $form = W ] && sw=1 || sw=0
  PYTHONPATH=$D GPCNAV_EXP_WALLS_SEARCH=$sw gpcnav evaluate $(ls out/ng-corridor/*.toml) --controller gpc \
    --workers 2 --out $O/$form-ng-corridor.json > $O/$form-ng-corridor.log 2>&1
  echo "$form ng-corridor $(date +%T)"
done
for form in base W; do
  [ $form = W ] && sw=1 || sw=0
  PYTHONPATH=$D GPCNAV_EXP_WALLS_SEARCH=$sw gpcnav evaluate --suite square-crossing --movers 20 --count 20 --seed 1 \
    --controller gpc --workers 2 --out $O/$form-s1-sq20-20.json > $O/$form-s1-sq20-20.log 2>&1
  echo "$form sq20 $(date +%T)"
done
