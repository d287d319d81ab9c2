#!/bin/bash
# rule.md's runs. Usage: run.sh B|T|NB|NT OUTDIR [REPO]. B runs the shipped code (REPO: a worktree of
# b24ba07, its own PYTHONPATH); T the same sets with the GPC's check given robust_drive_ties
# (sitecustomize.py here, GPCNAV_EXP_TIES=1). NB and NT (nn_rule.md): the deployed network, its check
# as shipped (REPO: a worktree of the commit before) and with robust_drive_ties (GPCNAV_EXP_NN_TIES=1).
form=$1; out=$2; repo=${3:-$(pwd)}
here=$(cd "$(dirname "$0")" && pwd)
export PATH=/work/main/.venv/bin:$PATH
mkdir -p "$out"
cd "$repo"
controller=gpc
case $form in
  T) export PYTHONPATH="$repo:$here" GPCNAV_EXP_TIES=1 ;;
  NT) export PYTHONPATH="$repo:$here" GPCNAV_EXP_NN_TIES=1; controller=nn ;;
  NB) export PYTHONPATH="$repo"; controller=nn ;;
  *) export PYTHONPATH="$repo" ;;
esac
ng=$(ls "$out"/../ng-corridor/*.toml)
while read -r name args; do
  [ -z "$name" ] && continue
  if [ "$name" = ng ]; then set -- $ng; else set -- $args --seed 43; fi
  gpcnav evaluate "$@" --controller $controller --workers 2 --out "$out/$form-$name.json" > "$out/$form-$name.log" 2>&1
  rc=$?
  echo "$form $name $(date +%T) rc=$rc"
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
