#!/bin/bash
# the GPC's tables of record in buildings, seed 1, with the walls forecast:
#   run.sh OUT REPO   (REPO: a worktree of the code to run; seed1/ was made at 946cc2f, ../final/ at a855f74)
out=$1; repo=$2
export PATH=/work/main/.venv/bin:$PATH PYTHONPATH=$repo
cd "$repo"
for s in corridor doorway corner; do
  gpcnav evaluate --suite $s --count 200 --seed 1 --controller gpc --workers 2 --out $out/$s.json > $out/$s.log 2>&1
  echo "$s $(date +%T) rc=$?"
done
gpcnav evaluate /work/main/out/ng-corridor/*.toml --controller gpc --workers 2 --out $out/ng.json > $out/ng.log 2>&1
echo "ng $(date +%T) rc=$?"
gpcnav evaluate --suite random-multi --count 40 --seed 1 --controller gpc --workers 2 --out $out/randommulti40.json > $out/rm.log 2>&1
echo "rm $(date +%T) rc=$?"
