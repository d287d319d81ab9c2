#!/bin/bash
# the runs of rule.md: the shipped network (base) and C (no walls network) on seed 8 of the
# three wall suites, then navground's corridor from navground seeds 201-400 (out/ng-corridor-201)
. .venv/bin/activate
D=docs/data/buildings/nn_wallnet
O=out/nnw
mkdir -p $O
for suite in corridor doorway corner; do
  for form in base C; do
    [ $form = C ] && sw=1 || sw=0
    PYTHONPATH=$D GPCNAV_EXP_NN_NOWALLNET=$sw gpcnav evaluate --suite $suite --count 200 --seed 8 --controller nn \
      --workers 2 --out $O/$form-s8-$suite.json > $O/$form-s8-$suite.log 2>&1
    echo "$form s8 $suite $(date +%T)"
  done
done
for form in C base; do
  [ $form = C ] && sw=1 || sw=0
  PYTHONPATH=$D GPCNAV_EXP_NN_NOWALLNET=$sw gpcnav evaluate $(ls out/ng-corridor-201/*.toml) --controller nn \
    --workers 2 --out $O/$form-ng201.json > $O/$form-ng201.log 2>&1
  echo "$form ng-corridor-201 $(date +%T)"
done
