#!/bin/bash
# after run_seed1.sh: the held-out recordings (gpcnav import-tracks FILE --max-cases 20 [--behaviour orca]
# into out/held2/{replay,reactive}/NAME: the 78 cases of docs/data/pedestrians/held_out_recordings/)
# and navground's Corridor (out/ng-corridor: tools/export_navground_scenario.py --scene corridor --count 200 --seed 1)
. .venv/bin/activate
O=out/rdi1
while ! grep -q "^paper" out/rdi1.log 2>/dev/null; do sleep 10; done
gpcnav evaluate out/held2/replay/*/*.toml --controller gpc --workers 2 --out $O/gpc-held-replay.json > $O/gpc-held-replay.log 2>&1
echo "held replay $(date +%T)"
gpcnav evaluate out/held2/reactive/*/*.toml --controller gpc --workers 2 --out $O/gpc-held-reactive.json > $O/gpc-held-reactive.log 2>&1
echo "held reactive $(date +%T)"
gpcnav evaluate $(ls out/ng-corridor/*.toml) --controller gpc --workers 2 --out $O/gpc-ng-corridor.json > $O/gpc-ng-corridor.log 2>&1
echo "ng corridor $(date +%T)"
