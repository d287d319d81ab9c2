"""gpcnav bench --preset improved --solvers ipopt-warm,sqpmethod-daqp+fatrop, with every pause of Python's garbage
collector logged (gc.callbacks); the pauses over 10 ms and the full collections printed on stderr at the end."""
import gc, time, sys
log = []
def cb(phase, info):
    if phase == "start": log.append([time.perf_counter(), info["generation"]])
    else: log[-1].append(time.perf_counter())
gc.callbacks.append(cb)
from gpcnav.cli import main
main(["bench", "--preset", "improved", "--solvers", "ipopt-warm,sqpmethod-daqp+fatrop", "--out", "BENCH.json"])
print("gc pauses > 10 ms:", [(g, round(e - s, 3)) for s, g, e in log if e - s > 0.01], file=sys.stderr)
print("gen2 count", sum(1 for _, g, _ in log if g == 2), file=sys.stderr)
