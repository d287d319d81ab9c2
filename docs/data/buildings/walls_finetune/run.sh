#!/usr/bin/env bash
# The fine-tuning dataset and its candidates (rule.md): run from the repository root.
#   bash docs/data/buildings/walls_finetune/run.sh [OUT]      (default out/wf; about 40 min on 2 cores)
set -euo pipefail
OUT=${1:-out/wf}
HERE=docs/data/buildings/walls_finetune
D="$OUT/data"
E=nn_export/models/improved-walls.onnx
W=${WORKERS:-2}
round() {  # one round unless the dataset has it: round PART ARGS...
  local part=$1
  shift
  grep -q "\"$part\"" "$D/manifest.json" || gpcnav dataset --out "$D" "$@" --preset improved --workers "$W"
}
[ -f "$D/manifest.json" ] || gpcnav dataset --out "$D" --samples 2000 --preset improved --layout set-walls --seed 9100 \
  --workers "$W"
for s in 9101 9102; do [ -d "$OUT/scenes-$s" ] || python "$HERE/scenes.py" "$OUT/scenes-$s" "$s" 300; done
[ -d "$OUT/navground" ] || python tools/export_navground_scenario.py --scene corridor --out "$OUT/navground" \
  --count 40 --seed 26101
round gpc70 --dagger gpc --dagger-files "$OUT"/scenes-9101/*.toml --dagger-noise 0.05 --round 70
round dagger71 --dagger "$E" --dagger-files "$OUT"/scenes-9102/*.toml --round 71
round gpc72 --dagger gpc --dagger-suite corridor --movers 5 --behaviour orca --episodes 60 --dagger-noise 0.05 --round 72
round gpc73 --dagger gpc --dagger-suite doorway --movers 5 --behaviour orca --episodes 60 --dagger-noise 0.05 --round 73
round gpc74 --dagger gpc --dagger-suite corner --movers 5 --behaviour orca --episodes 60 --dagger-noise 0.05 --round 74
round gpc75 --dagger gpc --dagger-suite corner --movers 5 --behaviour social_force --episodes 30 --dagger-noise 0.05 \
  --round 75
round gpc76 --dagger gpc --dagger-files "$OUT"/navground/*.toml --dagger-noise 0.05 --round 76
