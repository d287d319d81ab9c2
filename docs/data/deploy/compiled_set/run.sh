#!/bin/bash
# the network's tables of record on seed 1 with the compiled set networks (REPO: a worktree of the commit)
repo=$1; out=$2
export PATH=/work/main/.venv/bin:$PATH PYTHONPATH=$repo
cd $repo
ng=$(ls /work/main/out/ng-corridor/*.toml)
while read -r name args; do
  [ -z "$name" ] && continue
  if [ "$name" = ng ]; then set -- $ng; else set -- $args --seed 1; fi
  gpcnav evaluate "$@" --controller nn --workers 2 --out "$out/$name.json" > "$out/$name.log" 2>&1
  echo "$name $(date +%T) rc=$?"
done <<'SETS'
circle5 --suite circle-crossing --movers 5 --count 200
circle10 --suite circle-crossing --movers 10 --count 200
square5 --suite square-crossing --movers 5 --count 200
randommulti --suite random-multi --count 200
corridor --suite corridor --count 200
doorway --suite doorway --count 200
corner --suite corner --count 200
ucy452 --suite ucy --count 452
ucyr452 --suite ucy --count 452 --behaviour orca
ng ng
SETS
echo DONE
