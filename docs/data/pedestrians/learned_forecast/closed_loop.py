"""Closed loop: the GPC behind its check (as ``gpcnav --controller gpc`` runs it) with the
learned forecast in place of its EKF's for every walker measured at the last 9 samples (the
others keep the EKF's), as tools/oracle_forecasts.py swaps in the truth.

    python closed_loop.py MODEL.onnx SUITE SEED MOVERS EPISODES(A-B) [BEHAVIOUR] [--ekf] [--ekf-means] [--union]
        [--cov=learned|ekf|max|fixedS]
    python closed_loop.py MODEL.onnx files 'GLOB' 0 EPISODES(A-B) [--ekf]   (scenario files, sorted)

``--ekf-means``: keep the EKF's means and swap only the covariances (with ``--cov=fixedS``).

``--union``: keep the EKF's forecast of each such walker and add the learned one beside it, as a
second mover (its id + ``UNION_ID``): the planner and its check avoid both hypotheses (with
``--cov=ekf``, the learned means with the EKF's covariances).

``--cov``: the learned forecast's own deviations (default), the EKF's covariances with the
learned means (``ekf``), the EKF's widened to the learned where that is wider (``max``), or
one fixed deviation for every step (``fixedS``, S in m).
"""
import sys
from pathlib import Path

import numpy as np
import onnxruntime as ort

from casadi_gpc.config import preset
from casadi_gpc.planner.gpc import GPCController
from casadi_gpc.safety import Shield
from casadi_gpc.types import ObstacleForecast
from gpcnav.commands.common import for_run
from gpcnav.controllers import check_settings
from scenarios import Suite
from scenarios.loader import load_scenario
from scenarios.metrics import episode_metrics
from scenarios.simulator import simulate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from data import H, PAST, SECTORS, features  # noqa: E402
from nn_export.runtime.wall_scan import wall_segment_rows  # noqa: E402


UNION_ID = 10_000_000


class LearnedForecast:
    """The walkers' measured positions of the last PAST + 1 samples and the learned forecast."""

    def __init__(self, path: str, sample_time_s: float, cov: str = "learned"):
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = opts.inter_op_num_threads = 1
        self.sess = ort.InferenceSession(path, opts, providers=["CPUExecutionProvider"])
        self.T, self.cov, self.means = sample_time_s, cov, "learned"
        self.union = False
        self.reads_walls = self.sess.get_inputs()[0].shape[1] == 2 * PAST + 40 + SECTORS
        self.reset()

    def reset(self):
        self._walls = None
        self.hist = {}  # id -> {sample: (x, y)}

    def _fixed(self) -> np.ndarray:
        """``--cov=fixedS``: S m for every step, as covariances (H, 2, 2)."""
        return float(self.cov[5:]) ** 2 * np.tile(np.eye(2), (H, 1, 1))

    def __call__(self, obs, own):
        if self.means == "ekf":  # the EKF's own means for every track, only the deviation swapped
            if not self.cov.startswith("fixed"):
                return list(own)
            return [ObstacleForecast(f.obstacle_id, f.radius_m, np.asarray(f.means_m), self._fixed()) for f in own]
        k = int(round(obs.t_s / self.T))
        for m in obs.moving:
            if m.position_m is not None and all(np.isfinite(m.position_m)):
                h = self.hist.setdefault(m.obstacle_id, {})
                h[k] = tuple(m.position_m)
                for old in [s for s in h if s < k - PAST]:
                    del h[old]
        ids = sorted(self.hist)
        meas = np.full((PAST + 1, len(ids), 2), np.nan)
        for c, i in enumerate(ids):
            for s, p in self.hist[i].items():
                if s >= k - PAST:  # a walker not measured lately keeps older rows
                    meas[s - (k - PAST), c] = p
        col = {i: c for c, i in enumerate(ids)}
        walls = None
        if self.reads_walls:  # the map's segments, made once
            if self._walls is None:
                self._walls = wall_segment_rows(obs.walls) if obs.walls else np.zeros((0, 4))
            walls = self._walls
        rows, where = [], []
        for n, f in enumerate(own):
            c = col.get(f.obstacle_id)
            ft = None if c is None else features(meas, PAST, c, walls)
            if ft is not None:
                rows.append(ft)
                where.append(n)
        out = list(own)
        if rows:
            X = np.array([r[0] for r in rows], dtype=np.float32)
            Y = self.sess.run(None, {"x": X})[0].astype(float)
            for (x, c, s), n, y in zip(rows, where, Y):
                f = own[n]
                R = np.array([[c, -s], [s, c]])
                now = meas[PAST, col[f.obstacle_id]]
                means = now + y[:2 * H].reshape(H, 2) @ R.T
                var = np.exp(2 * y[2 * H:])
                covs = var[:, None, None] * np.eye(2)[None]
                if self.cov == "ekf":  # the filter's own covariances: only the means are learned
                    covs = np.asarray(f.covs_m2)
                elif self.cov.startswith("fixed"):
                    covs = self._fixed()
                elif self.cov == "max":  # the filter's, widened where the learned one is wider
                    ekf = np.asarray(f.covs_m2)
                    lam = np.linalg.eigvalsh(ekf)[:, -1]
                    covs = ekf + np.maximum(var - lam, 0.0)[:, None, None] * np.eye(2)[None]
                if self.union:  # both hypotheses: the filter's and the learned one, as two movers
                    out.append(ObstacleForecast(f.obstacle_id + UNION_ID, f.radius_m, means, covs))
                else:
                    out[n] = ObstacleForecast(f.obstacle_id, f.radius_m, means, covs)
        return out


class LearnedGPC(GPCController):
    forecaster = None

    def reset(self):
        super().reset()
        if self.forecaster is not None:
            self.forecaster.reset()

    def estimate(self, obs):
        own = super().estimate(obs)
        return own if self.forecaster is None else self.forecaster(obs, own)


def main():
    model, suite, seed, movers, eps = sys.argv[1:6]
    rest = sys.argv[6:]
    behaviour = next((r for r in rest if not r.startswith("--")), "orca")
    a, b = (int(v) for v in eps.split("-"))
    if suite == "files":  # SEED is a glob of scenario files, EPISODES indices into them, sorted
        import glob
        paths = sorted(glob.glob(seed))
        S = type("Files", (), {"scenario": staticmethod(lambda i: load_scenario(paths[i]))})
    else:
        S = Suite(suite, b + 1, int(seed), int(movers), behaviour)
    got, approaching = [], 0
    for i in range(a, b + 1):
        sc = S.scenario(i)
        cfg = for_run(preset("improved"), [sc])
        gpc = LearnedGPC(cfg, sc.robot)
        if "--ekf" not in rest:
            cov = next((r.split("=", 1)[1] for r in rest if r.startswith("--cov=")), "learned")
            gpc.forecaster = LearnedForecast(model, cfg.sample_time_s, cov)
            gpc.forecaster.union = "--union" in rest
            if "--ekf-means" in rest:
                gpc.forecaster.means = "ekf"
        log = simulate(sc, Shield(gpc, sc.robot, check_settings("gpc", gpc, cfg, "on"), planner_config=cfg), "gpc-lp")
        t = np.array(log.compute_time_s) * 1e3
        m = episode_metrics(log)
        got.append(log.outcome)
        approaching += m.robot_approaching
        print(f"episode {i:4d}: {log.outcome:12s} clearance {log.min_clearance_m:6.3f} m  decision median "
              f"{np.median(t):.2f} ms  interventions {m.interventions}"
              + ("  robot approaching" if m.robot_approaching else ""), flush=True)
    print(", ".join(f"{got.count(o)} {o}" for o in ("reached_goal", "collided", "timed_out")) + f" of {len(got)}"
          + f" ({approaching} with the robot approaching)")


if __name__ == "__main__":
    main()
