"""Experiment switch (not shipped): GPCNAV_EXP_CV=k plans with a constant-velocity mean from
the last k measured displacements (the EKF's covariances kept); falls back to the EKF's mean
where a track lacks k+1 consecutive measurements."""
import os
if os.environ.get("GPCNAV_EXP_CV"):
    import numpy as np
    from casadi_gpc.planner import gpc as G
    from casadi_gpc.types import ObstacleForecast
    K = int(os.environ["GPCNAV_EXP_CV"])
    _orig = G.GPCController.estimate

    def estimate(self, obs):
        own = _orig(self, obs)
        hist = self.__dict__.setdefault("_cv_hist", {})
        k_now = int(round(obs.t_s / self.config.sample_time_s))
        if k_now == 0:
            hist.clear()
        H = self.config.horizon
        seen = set()
        for m in obs.moving:
            z = m.position_m
            if z is None or not np.all(np.isfinite(z)):
                continue
            h = hist.setdefault(m.obstacle_id, [])
            if h and h[-1][0] != k_now - 1:
                h.clear()
            h.append((k_now, np.asarray(z, dtype=float)))
            del h[:-(K + 1)]
            seen.add(m.obstacle_id)
        for j in list(hist):
            if j not in seen:
                del hist[j]
        out = []
        for f in own:
            h = hist.get(f.obstacle_id)
            if h is not None and len(h) == K + 1 and h[-1][0] == k_now:
                v = (h[-1][1] - h[0][1]) / K
                means = h[-1][1] + np.arange(1, H + 1)[:, None] * v
                out.append(ObstacleForecast(f.obstacle_id, f.radius_m, means, np.asarray(f.covs_m2)))
                self.counters["cv_forecasts"] = self.counters.get("cv_forecasts", 0) + 1
            else:
                out.append(f)
        return out

    G.GPCController.estimate = estimate

if os.environ.get("GPCNAV_EXP_ORCA"):
    # Experiment (not shipped): an interaction-aware forecast. The tracked walkers are simulated
    # ahead as navground ORCA walkers among themselves (the robot unseen), each from the filter's
    # position and velocity now, heading for a point far along its mean direction since it was
    # first seen, at the fastest speed its filter has estimated; the filter's covariances kept.
    import types as _types
    import numpy as np
    from casadi_gpc.planner import gpc as G
    from casadi_gpc.types import ObstacleForecast
    from scenarios.movers import MoverWorld
    _orig2 = G.GPCController.estimate

    def estimate2(self, obs):
        own = _orig2(self, obs)
        T, H = self.config.sample_time_s, self.config.horizon
        hist = self.__dict__.setdefault("_orca_hist", {})
        if int(round(obs.t_s / T)) == 0:
            hist.clear()
        specs, idx = [], []
        for i, f in enumerate(own):
            m = np.asarray(f.means_m)
            v = (m[1] - m[0]) / T
            p0 = m[0] - v * T
            speed = float(np.hypot(*v))
            h = hist.setdefault(f.obstacle_id, [p0.copy(), 0.0])
            if os.environ.get("GPCNAV_EXP_ORCA") == "cv":  # its velocity now, kept as its wish
                h[1], d = speed, v
            else:
                h[1] = max(h[1], speed)
                d = p0 - h[0]
                if np.hypot(*d) < 0.5:
                    d = v
            n = float(np.hypot(*d))
            if n < 1e-6 or h[1] < 0.05:
                continue
            specs.append(_types.SimpleNamespace(behaviour="orca", radius_m=float(f.radius_m), position_m=p0,
                                                goal_m=p0 + d / n * 100.0, preferred_speed_mps=h[1], sees_robot=False))
            idx.append(i)
        if len(specs) < 2:
            return own
        world = MoverWorld(specs, obs.static, 0.35, getattr(obs, "walls", ()) or ())
        world._vel = np.array([(np.asarray(own[i].means_m)[1] - np.asarray(own[i].means_m)[0]) / T for i in idx])
        world.advance(H * T)
        P = world.positions(np.arange(1, H + 1) * T)  # (H, n, 2)
        out = list(own)
        for k, i in enumerate(idx):
            out[i] = ObstacleForecast(own[i].obstacle_id, own[i].radius_m, np.ascontiguousarray(P[:, k]),
                                      np.asarray(own[i].covs_m2))
        self.counters["orca_forecasts"] = self.counters.get("orca_forecasts", 0) + len(idx)
        return out

    G.GPCController.estimate = estimate2

if os.environ.get("GPCNAV_EXP_EKFX"):
    # Experiment (not shipped): the planner's obstacle filter with its speed and heading
    # process noises multiplied by GPCNAV_EXP_EKFX (a filter that follows a walker's change
    # sooner, and says it is less sure).
    import dataclasses
    from casadi_gpc.estimation.ekf import EKFSettings
    from casadi_gpc.planner import gpc as G
    _k = float(os.environ["GPCNAV_EXP_EKFX"])
    _S0 = EKFSettings()
    _S = dataclasses.replace(_S0, speed_noise_mps2=_S0.speed_noise_mps2 * _k, heading_noise_rad=_S0.heading_noise_rad * _k)
    _init = G.GPCController.__post_init__

    def __post_init__(self):
        self.ekf_settings = _S
        _init(self)

    G.GPCController.__post_init__ = __post_init__

if os.environ.get("GPCNAV_EXP_EKFMEAN"):
    # Experiment (not shipped): the forecasts' means from a second filter per track whose speed
    # and heading process noises are GPCNAV_EXP_EKFMEAN times the shipped (it follows a change
    # sooner), their covariances from the shipped filter (as sure as the planner is today).
    import dataclasses
    import numpy as np
    from casadi_gpc.estimation.ekf import EKFSettings
    from casadi_gpc.estimation.tracking import TrackBank
    from casadi_gpc.planner import gpc as G
    from casadi_gpc.types import ObstacleForecast
    _km = float(os.environ["GPCNAV_EXP_EKFMEAN"])
    _S0m = EKFSettings()
    _Sm = dataclasses.replace(_S0m, speed_noise_mps2=_S0m.speed_noise_mps2 * _km,
                              heading_noise_rad=_S0m.heading_noise_rad * _km)
    _orig3 = G.GPCController.estimate

    def estimate3(self, obs):
        own = _orig3(self, obs)
        if int(round(obs.t_s / self.config.sample_time_s)) == 0 or "_mean_bank" not in self.__dict__:
            self._mean_bank = TrackBank(self.config.sample_time_s, _Sm, {}, straight=self.config.forecast == "straight")
        bank = self._mean_bank
        fast = {f.obstacle_id: f for f in bank.forecasts(bank.step(obs.moving), self.config.horizon,
                                                         self._forecast_function)}
        out = []
        for f in own:
            g = fast.get(f.obstacle_id)
            out.append(f if g is None else ObstacleForecast(f.obstacle_id, f.radius_m, np.asarray(g.means_m),
                                                            np.asarray(f.covs_m2)))
        return out

    G.GPCController.estimate = estimate3
