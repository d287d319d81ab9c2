#!/usr/bin/env bash
# the rule's runs (rule.md): each side of each set, two at a time on the two cores; REPO: a worktree of the
# rule's commit (default: this checkout)
set -u
repo=${1:-$(cd "$(dirname "$0")/../../../../.." && pwd)}
export PATH=/work/main/.venv/bin:$PATH PYTHONPATH="$repo"
cd "$repo/docs/data/pedestrians/learned_forecast"
M=/work/main/out/lp/walls1.onnx
NG='/work/main/out/lp/ng-6901/*.toml'
out=union/rule
mkdir -p $out
for s in corner doorway corridor; do
  python closed_loop.py $M $s 44 5 0-199 --ekf > $out/$s-44-ekf.txt 2>&1 &
  python closed_loop.py $M $s 44 5 0-199 --union --cov=ekf > $out/$s-44-union.txt 2>&1
  wait
done
python closed_loop.py $M files "$NG" 0 0-98 --ekf > $out/ng-6901-ekf.txt 2>&1 &
python closed_loop.py $M files "$NG" 0 0-98 --union --cov=ekf > $out/ng-6901-union.txt 2>&1
wait
echo DONE
