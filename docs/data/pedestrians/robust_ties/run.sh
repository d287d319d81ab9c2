#!/bin/bash
# rule.md's runs. Usage: run.sh B|T OUTDIR [REPO]. B runs the shipped code (REPO: a worktree of
# b24ba07, its own PYTHONPATH); T the same sets with the GPC's check given robust_drive_ties
# (sitecustomize.py here, GPCNAV_EXP_TIES=1).
form=$1; out=$2; repo=${3:-$(pwd)}
here=$(cd "$(dirname "$0")" && pwd)
export PATH=/work/main/.venv/bin:$PATH
mkdir -p "$out"
cd "$repo"
if [ "$form" = T ]; then export PYTHONPATH="$repo:$here" GPCNAV_EXP_TIES=1; else export PYTHONPATH="$repo"; fi
ng=$(ls "$out"/../ng-corridor/*.toml)
while read -r name args; do
  [ -z "$name" ] && continue
  if [ "$name" = ng ]; then set -- $ng; else set -- $args --seed 43; fi
  gpcnav evaluate "$@" --controller gpc --workers 2 --out "$out/$form-$name.json" > "$out/$form-$name.log" 2>&1
  echo "$form $name $(date +%T) rc=$?"
done <<'SETS'
ucy --suite ucy --count 452
ucyr --suite ucy --count 452 --behaviour orca
sq30 --suite square-crossing --movers 30 --count 200
corner --suite corner --count 200
sq20 --suite square-crossing --movers 20 --count 200
corridor --suite corridor --count 200
doorway --suite doorway --count 200
ng
SETS
