#!/bin/bash
# Robots of other sizes (docs/model.md, "Robots of other sizes"): the same episodes with the
# robot's radius 0.22, 0.28 and 0.35 m (the shipped robot's), the GPC and the deployed network
# (planner-free check); among recorded people the two baselines beside them. Run from the
# repository's root; the scenario files go to out/robot_size/ (not kept), the documents here.
set -e
here=docs/data/robot_size
for r in 0.22 0.28 0.35; do
  for case in "circle-crossing 40 50 10 -" "corridor 40 50 - -" "ucy 40 50 - orca"; do
    set -- $case
    dir=out/robot_size/$1-$r
    python $here/make_files.py $1 $2 $3 $4 $5 $r $dir
    controllers=gpc,nn
    [ "$1" = ucy ] && controllers=stand,blind,gpc,nn
    gpcnav compare $dir/*.toml --controllers $controllers --workers 2 --out $here/$1-$r/COMPARE.json 2>&1 | tail -${#controllers}
  done
done
