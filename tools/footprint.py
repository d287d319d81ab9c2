"""The deployment footprint of the network controller, measured in a fresh process.

    python tools/footprint.py [--preset improved] [--decisions 1000] [--movers 1]

Starts a new Python process that imports only what the deployed policy needs
(``nn_export.OnnxPolicy``: numpy, onnxruntime and numba; torch and casadi are made unimportable),
loads the model shipped for the preset, and makes N decisions on a straight reference with a
head-on obstacle (``--movers M``: M obstacles abreast, which hands the decisions to the
shipped crowd network, ``crowd_decisions``). Prints, as JSON: the time from the process start to the first decision's
readiness (interpreter start-up, imports and model load: ``ready_s``), the load time alone,
the median decision time, and the process's peak resident set (``VmHWM``).
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import sys, time, json, resource
t_start = float(sys.argv[1]); preset = sys.argv[2]; n = int(sys.argv[3]); movers = int(sys.argv[4])
def peak_rss_mb():
    # VmHWM belongs to this process's own memory map; ru_maxrss would also count the parent's
    # pages a vfork-ed child shared before exec (a pytest parent shows up as 400 MB)
    try:
        for line in open("/proc/self/status"):
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
class _Block:  # torch and casadi must not be needed
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("torch", "casadi"):
            raise ImportError(f"{name} is blocked in the deployment footprint")
        return None
sys.meta_path.insert(0, _Block())
from nn_export import OnnxPolicy
from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotState, robot_step_float
from casadi_gpc.types import Observation, ObstacleMeasurement
t0 = time.perf_counter()
policy = OnnxPolicy(preset=preset)
load_s = time.perf_counter() - t0
ready_s = time.time() - t_start
ref = ReferencePath((0.0, 0.0), 0.0, (Segment.line(1000.0),), 0.4)
T, W = policy.sample_time_s, policy.robot.wheel_base_m
x = y = h = vr = vl = 0.0
times = []
for k in range(n):
    ox = 12.0 - 0.3 * T * (k % 60)  # an obstacle coming head-on, a new one every 60 samples
    obs = Observation(k * T, RobotState(x, y, h, vr, vl), ref,
                      tuple(ObstacleMeasurement(movers * (k // 60) + i,
                                                (x + ox + 0.5 * i, 0.9 * (i - (movers - 1) / 2)), 0.3)
                            for i in range(movers)))
    a = time.perf_counter()
    d = policy.decide(obs)
    times.append(time.perf_counter() - a)
    vr, vl = d.v_right_mps, d.v_left_mps
    x, y, h = robot_step_float(x, y, h, vr, vl, T, W)
times.sort()
print(json.dumps({"preset": preset, "decisions": n, "movers": movers, "ready_s": ready_s, "load_s": load_s,
                  "crowd_decisions": policy.counters["crowd_network"],
                  "decision_median_s": times[n // 2],
                  "peak_rss_mb": peak_rss_mb(),
                  "torch_loaded": "torch" in sys.modules, "casadi_loaded": "casadi" in sys.modules}))
"""


def measure(preset: str = "improved", decisions: int = 1000, movers: int = 1) -> dict:
    out = subprocess.run([sys.executable, "-c", CHILD, repr(time.time()), preset, str(decisions), str(movers)],
                         capture_output=True, text=True, cwd=ROOT, timeout=300)
    if out.returncode != 0:
        raise RuntimeError(out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "child failed")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="improved", choices=("paper", "improved"))
    ap.add_argument("--decisions", type=int, default=1000)
    ap.add_argument("--movers", type=int, default=1)
    args = ap.parse_args(argv)
    print(json.dumps(measure(args.preset, args.decisions, args.movers), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
