#!/bin/sh
# Closed loop, the code before (BASE, a worktree) and after (HEAD): the same suites run with each,
# then every episode compared (compare.py). Usage: sh closedloop.sh BASE HEAD OUTDIR
BASE=$1; HEAD=$2; OUT=$3
mkdir -p "$OUT"
for v in base head; do
  if [ $v = base ]; then R=$BASE; else R=$HEAD; fi
  E="python -m gpcnav evaluate --seed 1 --workers 2"
  PYTHONPATH=$R $E --suite circle-crossing --movers 10 --count 40 --controller nn \
    --out "$OUT/$v-crowd10-nn.json" >/dev/null
  PYTHONPATH=$R $E --suite corridor --count 20 --controller nn --out "$OUT/$v-corridor-nn.json" >/dev/null
  PYTHONPATH=$R $E --suite circle-crossing --movers 10 --count 10 --controller gpc \
    --out "$OUT/$v-crowd10-gpc.json" >/dev/null
done
python "$(dirname "$0")/compare.py" "$OUT"
