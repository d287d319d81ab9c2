#!/usr/bin/env bash
# Regenerate the README's figures and docs/report_full.md from a full `gpcnav reproduce` run.
#   tools/update_readme_figures.sh [OUT_DIR]     (default out/full; under 30 min on 2 cores)
set -euo pipefail
OUT=${1:-out/full}
gpcnav reproduce --out "$OUT"
cp "$OUT/fig6_training_error.png" "$OUT/fig7_scenarios.png" "$OUT/timing.png" docs/
cp "$OUT/report.md" docs/report_full.md
cp "$OUT/results.json" docs/data/reproduce_full_results.json
