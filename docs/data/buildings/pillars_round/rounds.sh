#!/usr/bin/env bash
# Rounds of the walls network's data with a pillar in the three wall suites (docs/buildings.md,
# "Pillars in the walls network's data"): the GPC driving with DART noise (gpc70-72), then the
# shipped walls network driving bare (dagger73-75), appended to the walls network's dataset D
# (the one tools/build_models.sh makes; improved-walls = its parts up to dagger34). FILES: the
# folder make_files.py wrote the scenario files into (one folder a seed).
set -euo pipefail
D=${D:-out/walls2/data}
FILES=${FILES:-out/pillars/files}
M=${M:-nn_export/models/improved-walls.onnx}
round() { local part=$1; shift; grep -q "\"$part\"" "$D/manifest.json" || gpcnav dataset --out "$D" "$@" --preset improved --workers 2; }
for s in 9001 9002 9003; do
  [ -d "$FILES/$s" ] || python docs/data/buildings/pillars_round/make_files.py \
    "$(case $s in 9001) echo corridor;; 9002) echo doorway;; *) echo corner;; esac)" 60 "$s" "$FILES/$s"
done
for s in 9011 9012 9013; do
  [ -d "$FILES/$s" ] || python docs/data/buildings/pillars_round/make_files.py \
    "$(case $s in 9011) echo corridor;; 9012) echo doorway;; *) echo corner;; esac)" 100 "$s" "$FILES/$s"
done
round gpc70 --dagger gpc --dagger-files "$FILES"/9001/*.toml --round 70 --dagger-noise 0.05
round gpc71 --dagger gpc --dagger-files "$FILES"/9002/*.toml --round 71 --dagger-noise 0.05
round gpc72 --dagger gpc --dagger-files "$FILES"/9003/*.toml --round 72 --dagger-noise 0.05
round dagger73 --dagger "$M" --dagger-files "$FILES"/9011/*.toml --round 73
round dagger74 --dagger "$M" --dagger-files "$FILES"/9012/*.toml --round 74
round dagger75 --dagger "$M" --dagger-files "$FILES"/9013/*.toml --round 75
echo DONE-ROUNDS
