"""Trace the oracle GPC's plans against the truth: per decision, the worst gap of the
planner's own plan, at which step, with which walker, and whether that walker was in the
NLP's slots and in the scene; the shield's verdict."""
import sys
from pathlib import Path
import numpy as np
sys.path.insert(0, str(Path(__file__).resolve().parents[4] / "tools"))  # the repository's tools/
from oracle_forecasts import OracleGPC, true_positions
from casadi_gpc.config import preset
from casadi_gpc.safety import Shield
from gpcnav.commands.common import for_run
from gpcnav.controllers import check_settings
from scenarios import Suite
from scenarios.simulator import simulate

seed, movers, ep = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
suite = Suite(sys.argv[4] if len(sys.argv) > 4 else "square-crossing", ep + 1, seed, movers, "orca")
sc = suite.scenario(ep)
cfg = for_run(preset("improved"), [sc])
T, H = cfg.sample_time_s, cfg.horizon
truth = true_positions(sc, T, H)
present = np.isfinite(true_positions(sc, T, H, hold_absent=False)).all(axis=2)
radii = np.array([m.radius_m for m in sc.moving])
rec = []

class Traced(OracleGPC):
    def pose(self, obs, forecasts):
        tick, sel = super().pose(obs, forecasts)
        rec.append({"t": obs.t_s, "sel": sorted(f.obstacle_id for f in sel.forecasts),
                    "tracked": sorted(f.obstacle_id for f in forecasts)})
        return tick, sel

    def _decide(self, obs):
        d = super()._decide(obs)
        rec[-1]["plan"] = None if d.planned_poses is None else np.asarray(d.planned_poses).copy()
        return d

gpc = Traced(cfg, sc.robot)
gpc.use_truth(truth, radii, 0.05)
sh = Shield(gpc, sc.robot, check_settings("gpc", gpc, cfg, "on"), planner_config=cfg)
log = simulate(sc, sh, "gpc-oracle")
print("outcome", log.outcome, "collision", log.collision)
for k, (r, d) in enumerate(zip(rec, log.decisions)):
    line = f"t {r['t']:5.1f} sel {len(r['sel']):2d}/{len(r['tracked']):2d} shield {d.reason[:70] if d.reason else '-'}"
    if r.get("plan") is not None:
        p = r["plan"][:, None, :2]
        gaps = np.hypot(*(truth[k + 1:k + H + 1] - p).transpose(2, 0, 1)) - (sc.robot.radius_m + radii)
        gaps = np.where(present[k + 1:k + H + 1], gaps, np.inf)
        j, w = np.unravel_index(np.argmin(gaps), gaps.shape)
        if gaps[j, w] < 0.05:
            line += f" | plan gap {gaps[j, w]:6.3f} at step {j + 1} walker {w} in slots {w in r['sel']} tracked {w in r['tracked']}"
    print(line)
