import json, sys, numpy as np
runs = [json.load(open(f)) for f in sys.argv[1:]]
names = list(runs[0])
same = all(runs[0][n]["cmds"] == r[n]["cmds"] and runs[0][n]["outcome"] == r[n]["outcome"] for r in runs for n in names)
print("identical decisions across runs:", same, len(names), "cases")
for f, r in zip(sys.argv[1:], runs):
    t = np.concatenate([r[n]["t"] for n in names]) * 1e3; c = np.concatenate([r[n]["chk"] for n in names]) * 1e3
    print(f"{f}: decision median {np.median(t):.3f} p99 {np.percentile(t,99):.2f} max {t.max():.2f} ms; check mean {c.mean():.3f} p99 {np.percentile(c,99):.2f}")
