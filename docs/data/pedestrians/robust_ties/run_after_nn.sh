#!/bin/bash
# nn_rule.md, once adopted: the network's tables of record (seed 1) and its four crowd suites, run once with
# the adopted check. Usage: run_after.sh OUTDIR [REPO] (REPO: a worktree of the adoption commit)
out=$1; repo=${2:-$(pwd)}
export PATH=/work/main/.venv/bin:$PATH PYTHONPATH="$repo"
mkdir -p "$out"; cd "$repo"
while read -r name args; do
  [ -z "$name" ] && continue
  if [ "$name" = ng ]; then set -- $(ls /work/main/out/ng-corridor/*.toml); else set -- $args --seed 1; fi
  gpcnav evaluate "$@" --controller nn --workers 2 --out "$out/$name.json" > "$out/$name.log" 2>&1
  rc=$?
  echo "$name $(date +%T) rc=$rc"
done <<'SETS'
circle5 --suite circle-crossing --movers 5 --count 200
circle10 --suite circle-crossing --movers 10 --count 200
square5 --suite square-crossing --movers 5 --count 200
randommulti --suite random-multi --count 200
ucy40 --suite ucy --count 40
ucyr40 --suite ucy --count 40 --behaviour orca
ucy452 --suite ucy --count 452
corner --suite corner --count 200
corridor --suite corridor --count 200
doorway --suite doorway --count 200
ng
ucyr452 --suite ucy --count 452 --behaviour orca
SETS
