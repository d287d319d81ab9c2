#!/bin/bash
# Once a rule adopted the tie-break, its runs on seed 1, run once with the adopted check.
# Usage: run_after.sh OUTDIR REPO [gpc|nn] (REPO: a worktree of the adoption commit).
# gpc (rule.md): the tables of record and the suites that must not change;
# nn (nn_rule.md): the network's four crowd suites and its tables of record.
out=$1; repo=${2:-$(pwd)}; controller=${3:-gpc}
export PATH=/work/main/.venv/bin:$PATH PYTHONPATH="$repo"
mkdir -p "$out"; cd "$repo"
gpc_sets="ucy40 ucyr40 ucy452 ucyr452 corner corridor doorway sq20 sq30 ng circle5 circle10 square5 random randommulti"
nn_sets="circle5 circle10 square5 randommulti ucy40 ucyr40 ucy452 corner corridor doorway ng ucyr452"
[ "$controller" = nn ] && sets=$nn_sets || sets=$gpc_sets
for name in $sets; do
  case $name in
    ucy40) args="--suite ucy --count 40" ;;
    ucyr40) args="--suite ucy --count 40 --behaviour orca" ;;
    ucy452) args="--suite ucy --count 452" ;;
    ucyr452) args="--suite ucy --count 452 --behaviour orca" ;;
    corner|corridor|doorway|random) args="--suite $name --count 200" ;;
    sq20) args="--suite square-crossing --movers 20 --count 200" ;;
    sq30) args="--suite square-crossing --movers 30 --count 200" ;;
    circle5) args="--suite circle-crossing --movers 5 --count 200" ;;
    circle10) args="--suite circle-crossing --movers 10 --count 200" ;;
    square5) args="--suite square-crossing --movers 5 --count 200" ;;
    randommulti) args="--suite random-multi --count 200" ;;
  esac
  if [ "$name" = ng ]; then set -- $(ls /work/main/out/ng-corridor/*.toml); else set -- $args --seed 1; fi
  gpcnav evaluate "$@" --controller "$controller" --workers 2 --out "$out/$name.json" > "$out/$name.log" 2>&1
  rc=$?
  echo "$name $(date +%T) rc=$rc"
done
