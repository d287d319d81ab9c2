#!/usr/bin/env bash
# The fine-tuning dataset and its candidates (rule.md): run from the repository root.
#   bash docs/data/buildings/walls_finetune/run.sh [OUT]      (default out/wf; about 40 min on 2 cores)
# E, the network trained further: the walls network shipped before c5 (rule4.md adopted c5 and it ships now), read
# from git at 36e3ff5 (sha256 d5db1fa6...), or the file the environment's E names (tools/build_models.sh gives its own).
# c1 and c2: E trained further on the first rounds (learning rates 1e-3 and 3e-4); c3: on those and a DAgger
# round driven by c1 bare (it collided at the door on the development cases, dev.sh).
set -euo pipefail
OUT=${1:-out/wf}
HERE=docs/data/buildings/walls_finetune
D="$OUT/data"
mkdir -p "$OUT"
if [ -z "${E:-}" ]; then
  E="$OUT/E.onnx"
  [ -f "$E" ] || git show 36e3ff5:nn_export/models/improved-walls.onnx > "$E"
fi
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

tune() {  # tune NAME LR: E trained further on the whole dataset, exported
  [ -f "$OUT/models/$1.onnx" ] && return
  gpcnav train "$D" --out "$OUT/models/$1" --preset improved --architecture set --encoder-width 32 --hidden 64 \
    --layers 2 --seed 0 --optimizer adam --epochs 30 --patience 10 --batch-size 512 --relative --lr "$2" --init "$E"
  gpcnav export "$OUT/models/$1" --out "$OUT/models/$1.onnx" --passes 1
}
[ -f "$OUT/models/c1.onnx" ] || tune c1 1e-3
[ -f "$OUT/models/c2.onnx" ] || tune c2 3e-4
C1="$OUT/models/c1.onnx"
[ -d "$OUT/scenes-9103" ] || python "$HERE/scenes.py" "$OUT/scenes-9103" 9103 150
[ -d "$OUT/navground2" ] || python tools/export_navground_scenario.py --scene corridor --out "$OUT/navground2" \
  --count 40 --seed 26141
round dagger77 --dagger "$C1" --dagger-suite doorway --movers 5 --behaviour orca --episodes 100 --round 77
round dagger78 --dagger "$C1" --dagger-suite corner --movers 5 --behaviour orca --episodes 60 --round 78
round dagger79 --dagger "$C1" --dagger-suite corridor --movers 5 --behaviour orca --episodes 60 --round 79
round dagger80 --dagger "$C1" --dagger-files "$OUT"/navground2/*.toml --round 80
round dagger81 --dagger "$C1" --dagger-files "$OUT"/scenes-9103/*.toml --round 81
tune c3 1e-3
# c4 (rule2.md): one more DAgger round, driven by c3 bare, and E trained further on everything
C3="$OUT/models/c3.onnx"
[ -d "$OUT/scenes-9104" ] || python "$HERE/scenes.py" "$OUT/scenes-9104" 9104 150
[ -d "$OUT/navground3" ] || python tools/export_navground_scenario.py --scene corridor --out "$OUT/navground3" \
  --count 40 --seed 26181
round dagger82 --dagger "$C3" --dagger-suite corner --movers 5 --behaviour orca --episodes 100 --round 82
round dagger83 --dagger "$C3" --dagger-suite doorway --movers 5 --behaviour orca --episodes 100 --round 83
round dagger84 --dagger "$C3" --dagger-suite corridor --movers 5 --behaviour orca --episodes 60 --round 84
round dagger85 --dagger "$C3" --dagger-files "$OUT"/navground3/*.toml --round 85
round dagger86 --dagger "$C3" --dagger-files "$OUT"/scenes-9104/*.toml --round 86
tune c4 1e-3
# c5 (rule3.md): E trained further on the same dataset, its own answers as the labels outside the open buildings
if [ ! -f "$OUT/models/c5.onnx" ]; then
  python "$HERE/distil.py" "$D" "$E" "$OUT/models/c5"
  gpcnav export "$OUT/models/c5" --out "$OUT/models/c5.onnx" --passes 1
fi
