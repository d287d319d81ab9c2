"""Each set's episodes with the compiled set networks against the tables of record (the network with
onnxruntime, docs/data/pedestrians/robust_ties/nn_seed1/): outcomes, and the episodes that differ."""
import json, sys
from pathlib import Path
ref = Path(sys.argv[1]); new = Path(sys.argv[2])
def tally(d):
    ep = d["episodes_detail"]
    r = sum(e["outcome"] == "reached_goal" for e in ep); c = sum(e["outcome"] == "collided" for e in ep)
    return f"{r} / {c} ({d.get('collided_robot_approaching', 0)}) / {len(ep) - r - c}"
for name in ("circle5", "circle10", "square5", "randommulti", "corridor", "doorway", "corner", "ucy452", "ucyr452", "ng"):
    f = new / f"{name}.json"
    if not f.is_file():
        continue
    a, b = json.loads((ref / f"{name}.json").read_text()), json.loads(f.read_text())
    ea, eb = a["episodes_detail"], b["episodes_detail"]
    diff = [i for i, (x, y) in enumerate(zip(ea, eb)) if (x["outcome"], x.get("steps")) != (y["outcome"], y.get("steps"))]
    clr = max(abs(x["min_clearance_m"] - y["min_clearance_m"]) for x, y in zip(ea, eb))
    print(f"{name:12s} onnxruntime {tally(a):18s} compiled {tally(b):18s} episodes differing in outcome or steps: "
          f"{len(diff)} {diff[:8]}; largest clearance change {clr:.2g} m; decision median "
          f"{a['compute_time_s']['median']*1e3:.3f} -> {b['compute_time_s']['median']*1e3:.3f} ms")
