#!/usr/bin/env bash
# judge.sh NAME [OPTIONS...]: rule5.md's cases with the shipped networks, or the walls network OPTIONS give
# (`--walls-model FILE`), documents into docs/data/buildings/walls_widths/runs/NAME-*.json. From the repository
# root (its packages are the ones imported), after
#   python docs/data/buildings/walls_widths/scenes.py out/ww/judge/widths 9401 120
#   python docs/data/buildings/walls_finetune/scenes.py out/ww/judge/open 8304 60
#   python docs/data/buildings/one_wall/gen.py out/ww/judge/onewall 14
#   python tools/export_navground_scenario.py --scene corridor --out out/ww/judge/navground --count 100 --seed 7641
# gate NAME [OPTIONS...] runs the gate's development cases instead (GATE=1).
set -euo pipefail
N=$1
shift
J=$PWD/out/ww/judge R=$PWD/docs/data/buildings/walls_widths/runs
mkdir -p "$R"
ev() { python -m gpcnav evaluate "$@" --controller nn --workers 2 | tail -1; }
if [ "${GATE:-}" = 1 ]; then
  ev "$PWD"/out/ww/dev/*.toml --out "$R/$N-gate-widths.json" "$@"
  for s in corridor doorway corner; do ev --suite $s --count 20 --seed 2 --out "$R/$N-gate-$s-s2.json" "$@"; done
  exit 0
fi
ev "$J"/widths/*.toml --out "$R/$N-widths.json" "$@"
for s in corridor doorway corner; do ev --suite $s --count 200 --seed 85 --out "$R/$N-$s-s85.json" "$@"; done
ev "$J"/navground/*.toml --out "$R/$N-navground.json" "$@"
ev "$J"/open/*.toml "$J"/onewall/*.toml --out "$R/$N-open.json" "$@"
