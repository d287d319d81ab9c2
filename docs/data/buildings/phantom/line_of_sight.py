"""How long the person in each of the GPC's corner collisions (seeds 1 and 3) had been in the
robot's line of sight, without a break, before it: docs/buildings.md (the phantom). Run from
the repository root; writes its scenario files and runs under out/s3/."""
import json, numpy as np
from scenarios import Suite
from scenarios.writer import scenario_document, to_toml
from casadi_gpc.geometry import segments_cross
import subprocess
for seed, idx in [(1, 37), (1, 66), (1, 117), (1, 184), (3, 4), (3, 30), (3, 37), (3, 45), (3, 155), (3, 183), (3, 190)]:
    sc = Suite("corner", idx + 1, seed, 5).scenario(idx)
    f = f"out/s3/seen_{seed}_{idx}.toml"; open(f, "w").write(to_toml(scenario_document(sc)))
    subprocess.run(["gpcnav", "simulate", f, "--controller", "gpc", "--out", f + ".json"], capture_output=True)
    d = json.load(open(f + ".json"))
    if not d.get("collision"):
        print(seed, idx, d["outcome"]); continue
    k = d["collision"]["index"]; tc = d["collision"]["time_s"]
    tr = d["trajectory"]; t = np.array(tr["t"]); rx, ry = np.array(tr["x"]), np.array(tr["y"])
    ob = d["obstacles"][k]; ox, oy = np.array(ob["x"]), np.array(ob["y"])
    segs = np.array([(*a, *b) for w in d["walls"] for a, b in zip(w["points"][:-1], w["points"][1:])], float)
    n = min(len(t), len(ox))
    vis = []
    for i in range(n):
        if not np.isfinite(ox[i]): vis.append(False); continue
        vis.append(not segments_cross(np.array([[rx[i], ry[i]]]), np.array([[ox[i], oy[i]]]), segs[:, :2], segs[:, 2:]).any())
    vis = np.array(vis); ic = int(np.searchsorted(t, tc)) - 1
    j = ic
    while j >= 0 and vis[j]: j -= 1
    print(seed, idx, "collision at", tc, "person", k, "in view continuously for %.1f s" % (t[ic] - t[j + 1] if j + 1 <= ic else 0.0))
