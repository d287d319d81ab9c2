#!/usr/bin/env bash
# the rule's runs (rule.md): each side of each set, two at a time on the two cores
set -u
cd "$(dirname "$0")/.."
M=/work/main/out/lp/walls1.onnx
NG='/work/main/out/lp/ng-6601/*.toml'
for s in corner doorway corridor; do
  python closed_loop.py $M $s 34 5 0-199 --ekf > rule/$s-34-ekf.txt 2>&1 &
  python closed_loop.py $M $s 34 5 0-199 > rule/$s-34-learned.txt 2>&1
  wait
done
python closed_loop.py $M files "$NG" 0 0-99 --ekf > rule/ng-6601-ekf.txt 2>&1 &
python closed_loop.py $M files "$NG" 0 0-99 > rule/ng-6601-learned.txt 2>&1
wait
echo DONE
