"""Experiment (GPCNAV_EXP_STRAIGHT_CHECK=1): the check behind the deployed network judges
against the straight forecast of the network's own filter estimates (as the GPC's check does),
the network's features keep the turning one."""
import os
if os.environ.get("GPCNAV_EXP_STRAIGHT_CHECK") == "1":
    from casadi_gpc.safety import shield as _S
    from casadi_gpc.types import ObstacleForecast

    class _Straight:
        __slots__ = ("obstacle_id", "radius_m", "means_m", "covs_m2", "initialised")

    _orig = _S.Shield._forecasts

    def _forecasts(self, obs, dec):
        fc = _orig(self, obs, dec)
        if not getattr(self.policy, "provides_forecasts", False) or not hasattr(self.policy, "tracker"):
            return fc
        out = []
        for t in fc:
            f = getattr(t, "_filter", None)
            if f is None:
                f = t.batch_.snapshot(t.batch_index_)
            means, covs = f.predict(self.horizon, straight=True)
            s = _Straight()
            s.obstacle_id, s.radius_m, s.means_m, s.covs_m2 = t.obstacle_id, t.radius_m, means, covs
            s.initialised = getattr(t, "initialised", True)
            out.append(s)
        return out

    _S.Shield._forecasts = _forecasts
    _S._EXP_STRAIGHT = True
