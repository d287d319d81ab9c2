#!/usr/bin/env bash
# Rounds in buildings of other widths (scenes.py) for the walls network trained further from the shipped one (c5):
#   bash docs/data/buildings/walls_widths/run.sh [OUT]      (default out/ww; run from the repository root)
# The GPC with DART noise drives 300 scenes, the shipped network bare another 300, both labelled by the GPC; then
# c6: the shipped network trained further (walls_finetune/distil.py) on these rows and c5's own dataset, the GPC's
# labels on the open buildings' and these rounds' rows, the shipped network's own answers on every other row.
set -euo pipefail
OUT=${1:-out/ww}
HERE=docs/data/buildings/walls_widths
D="$OUT/data"
mkdir -p "$OUT"
if [ -z "${C5:-}" ]; then  # c5, the walls network shipped at 109d3ed (sha256 9b060ce7...), or the one C5 names
  C5="$OUT/c5.onnx"
  [ -f "$C5" ] || git show 109d3ed:nn_export/models/improved-walls.onnx > "$C5"
fi
W=${WORKERS:-2}
round() {  # one round unless the dataset has it: round PART ARGS...
  local part=$1
  shift
  grep -q "\"$part\"" "$D/manifest.json" || gpcnav dataset --out "$D" "$@" --preset improved --workers "$W"
}
[ -f "$D/manifest.json" ] || gpcnav dataset --out "$D" --samples 500 --preset improved --layout set-walls --seed 9200 \
  --workers "$W"
for s in 9201 9202; do [ -d "$OUT/scenes-$s" ] || python "$HERE/scenes.py" "$OUT/scenes-$s" "$s" 300; done
round gpc92 --dagger gpc --dagger-files "$OUT"/scenes-9201/*.toml --dagger-noise 0.05 --round 92
round dagger93 --dagger "$C5" --dagger-files "$OUT"/scenes-9202/*.toml --round 93
