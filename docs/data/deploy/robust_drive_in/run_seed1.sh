#!/bin/bash
# after adoption (rule.md): seed 1 of the seven suites, then the suites that must not change, then
# the held-out recordings (out/held/*-replay, made by gpcnav import-tracks --max-cases 20)
. .venv/bin/activate
O=out/rdi1
mkdir -p $O
for spec in "sq30 --suite square-crossing --movers 30 --count 200" "sq20 --suite square-crossing --movers 20 --count 200" \
            "corridor --suite corridor --count 200" "doorway --suite doorway --count 200" "corner --suite corner --count 200" \
            "ucy --suite ucy --count 40" "ucyr --suite ucy --count 40 --behaviour orca" \
            "circle5 --suite circle-crossing --movers 5 --count 200" "circle10 --suite circle-crossing --movers 10 --count 200" \
            "square --suite square-crossing --count 200" "randommulti --suite random-multi --count 200" \
            "random --suite random --count 200"; do
  set -- $spec; name=$1; shift 1
  gpcnav evaluate "$@" --seed 1 --controller gpc --workers 2 --out $O/gpc-s1-$name.json > $O/gpc-s1-$name.log 2>&1
  echo "s1 $name $(date +%T)"
done
gpcnav evaluate scenarios/paper/*.toml --controller gpc --workers 2 --out $O/gpc-paper.json > $O/gpc-paper.log 2>&1
echo "paper $(date +%T)"
