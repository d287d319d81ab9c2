#!/usr/bin/env bash
# The UCY tables of record measured again after the crowds_zara02 cases got back the people a
# rounding had dropped (docs/pedestrians.md, "The recordings' people, all of them"). Run from the
# repository root: bash docs/data/pedestrians/zara02_people/run.sh OUT_DIR
set -euo pipefail
OUT=${1:-docs/data/pedestrians/zara02_people}
W=${WORKERS:-2}
for c in gpc nn stand blind; do
  [ -f "$OUT/$c-replay-452.json" ] || gpcnav evaluate --suite ucy --count 452 --seed 1 --controller $c --workers $W \
    --out "$OUT/$c-replay-452.json"
  [ -f "$OUT/$c-reactive-452.json" ] || gpcnav evaluate --suite ucy --behaviour orca --count 452 --seed 1 \
    --controller $c --workers $W --out "$OUT/$c-reactive-452.json"
done
for b in replay orca; do
  [ -f "$OUT/compare-peers-40-$b.json" ] || gpcnav compare --suite ucy --behaviour $b --count 40 --seed 1 \
    --controllers orca,hrvo,social_force,mppi --workers $W --out "$OUT/compare-peers-40-$b.json"
done
