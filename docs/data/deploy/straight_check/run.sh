#!/usr/bin/env bash
# The runs of rule.md: each suite with the shipped check (0) and the option (1), one after the other.
set -u
OUT=${OUT:-out/sc}
mkdir -p "$OUT"
HERE=$(cd "$(dirname "$0")" && pwd)
run() {  # run NAME ARGS...
  local name=$1; shift
  for e in 0 1; do
    [ -f "$OUT/$name-$e.json" ] && continue
    PYTHONPATH="$HERE" GPCNAV_EXP_STRAIGHT_CHECK=$e gpcnav evaluate "$@" --controller nn --workers 2 \
      --out "$OUT/$name-$e.json" > "$OUT/$name-$e.log" 2>&1
  done
}
run cc5 --suite circle-crossing --movers 5 --count 200 --seed 1
run cc10 --suite circle-crossing --movers 10 --count 200 --seed 1
run sq5 --suite square-crossing --movers 5 --count 200 --seed 1
run rm --suite random-multi --count 200 --seed 1
run corridor --suite corridor --count 200 --seed 23
run doorway --suite doorway --count 200 --seed 23
run corner --suite corner --count 200 --seed 23
run sq20 --suite square-crossing --movers 20 --count 200 --seed 23
run ucy --suite ucy --count 40 --seed 23
run ucyr --suite ucy --behaviour orca --count 40 --seed 23
run ng $(ls out/ng-1701/*.toml)
