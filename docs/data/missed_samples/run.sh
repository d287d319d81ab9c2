# Dropped frames in closed loop (docs/faults.md): BEFORE is a worktree of the code before the change
# (d3788c4), AFTER this checkout; circle-crossing among 10 ORCA walkers, seed 64, 40 episodes.
BEFORE=${BEFORE:?a worktree of d3788c4}; AFTER=${AFTER:-.}
for c in nn gpc; do for p in 0.2 0.4; do for r in "$BEFORE" "$AFTER"; do
  PYTHONPATH=$r python docs/data/missed_samples/dropped.py $r $c 40 64 $p /dev/null; done; done
  PYTHONPATH=$AFTER python docs/data/missed_samples/dropped.py $AFTER $c 40 64 0.0 /dev/null; done
