#!/bin/bash
repo=/work/exp; out=/work/main/out/cs/rule
export PATH=/work/main/.venv/bin:$PATH
cd $repo
for side in ort compiled; do
  if [ $side = ort ]; then export GPCNAV_EXP_ORT=1; else export GPCNAV_EXP_ORT=0; fi
  export PYTHONPATH=$repo:/work/main/docs/data/deploy/compiled_set
  gpcnav evaluate --suite ucy --count 452 --behaviour orca --seed 47 --controller nn --workers 2 --out $out/ucyr47-$side.json > $out/ucyr47-$side.log 2>&1
  echo "ucyr47 $side $(date +%T) rc=$?"
  gpcnav evaluate $(ls /work/main/out/ng-7101/*.toml) --controller nn --workers 2 --out $out/ng7101-$side.json > $out/ng7101-$side.log 2>&1
  echo "ng7101 $side $(date +%T) rc=$?"
done
echo DONE
