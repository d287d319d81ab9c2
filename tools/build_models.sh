#!/usr/bin/env bash
# Rebuild the shipped networks nn_export/models/{paper,improved}.onnx from scratch:
# GPC labels (gpcnav dataset), training (gpcnav train), export (gpcnav export), then DAgger
# rounds: run the network on random episodes, label the states it visits with the GPC, add
# them to the dataset and retrain. Each round is evaluated on the random suite (seed 1).
#
#   tools/build_models.sh [OUT_DIR]        (default out/nn; about 1-2 h on 2 cores)
#
# The DAgger episodes use suite seeds 1000 * round (gpcnav dataset --dagger), never the
# evaluation seed 1. Settings (the ones the shipped models were made with; see docs/nn.md):
#   paper:    20000 samples + 3 DAgger rounds of 100 episodes
#   improved: 20000 samples + 2 DAgger rounds of 60 episodes
# The shipped files came from this sequence while the trainer was being developed: the
# models that drove the DAgger rounds were trained by earlier versions of it (Adam /
# one-iteration L-BFGS steps, wheel output basis), so a rebuild gives similar, not equal, files.
set -euo pipefail
OUT=${1:-out/nn}
WORKERS=${WORKERS:-2}
mkdir -p "$OUT/models" "$OUT/eval"

build() {
  local preset=$1 rounds=$2 episodes=$3 basis=$4
  local data="$OUT/data/$preset"
  gpcnav dataset --out "$data" --samples 20000 --preset "$preset" --layout paper --seed 0 --workers "$WORKERS"
  for r in $(seq 0 "$rounds"); do
    local m="$OUT/models/$preset-r$r"
    gpcnav train "$data" --out "$m" --preset "$preset" --seed 0 --output-basis "$basis"
    gpcnav export "$m" --out "$m.onnx"
    gpcnav evaluate --suite random --count 200 --seed 1 --controller nn --model "$m.onnx" --preset "$preset" \
      --no-safety-filter --workers "$WORKERS" --out "$OUT/eval/$preset-r$r-random.json"
    if [ "$r" -lt "$rounds" ]; then
      # the shipped models' rounds ran the network behind the safety filter (GPC on standby),
      # the behaviour of --dagger before --dagger-safety existed (its default is now off)
      gpcnav dataset --out "$data" --dagger "$m.onnx" --episodes "$episodes" --round $((r + 1)) \
        --preset "$preset" --seed 0 --workers 1 --dagger-safety gpc
    fi
  done
  cp "$OUT/models/$preset-r$rounds.onnx" "nn_export/models/$preset.onnx"
}

# output basis per preset: the one that did better on the random suite (docs/nn.md)
build paper 3 100 speed_turn
build improved 2 60 wheels

# the multi-obstacle layout (for the random-multi suite; not shipped)
gpcnav dataset --out "$OUT/data/paper-multi" --samples 10000 --preset paper --layout multi --seed 0 --workers "$WORKERS"
gpcnav train "$OUT/data/paper-multi" --out "$OUT/models/paper-multi" --preset paper --layout multi --seed 0
gpcnav export "$OUT/models/paper-multi" --out "$OUT/models/paper-multi.onnx"
