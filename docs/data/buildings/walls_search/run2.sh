#!/bin/bash
# the runs of rule2.md: the shipped check (base) and S on seed 8 of the three wall suites, then
# navground's Corridor exported afresh (out/ng-corridor-201), one worker
. .venv/bin/activate
D=docs/data/buildings/walls_search
O=out/ws2
mkdir -p $O
for suite in corridor doorway corner; do
  for form in base S; do
    [ $form = S ] && sw=1S || sw=0
    PYTHONPATH=$D GPCNAV_EXP_WALLS_SEARCH=$sw gpcnav evaluate --suite $suite --count 200 --seed 8 --controller gpc \
      --workers 2 --out $O/$form-s8-$suite.json > $O/$form-s8-$suite.log 2>&1
    echo "$form s8 $suite $(date +%T)"
  done
done
for form in S base; do
  [ $form = S ] && sw=1S || sw=0
  PYTHONPATH=$D GPCNAV_EXP_WALLS_SEARCH=$sw gpcnav evaluate $(ls out/ng-corridor-201/*.toml) --controller gpc \
    --workers 1 --out $O/$form-ng201.json > $O/$form-ng201.log 2>&1
  echo "$form ng-corridor-201 $(date +%T)"
done
