# experiment only: cold guesses started with the incumbent's shifted multipliers (the warm solver, SQP, takes them)
import os
if os.environ.get("GPCNAV_EXP_COLD") == "1":
    import casadi_gpc.planner.gpc as G
    from casadi_gpc.planner.candidates import shift
    _orig = G.GPCController._guess_starts
    def _gs(self, p, x0, ref, names=None, keep_one=True):
        out = _orig(self, p, x0, ref, names, keep_one)
        inc = self.candidates.incumbent
        if inc is None or inc.lam_x is None:
            return out
        _, lx, lg = shift(inc, self.config.horizon)
        return [(n, u, lx, lg) for n, u, _, _ in out]
    G.GPCController._guess_starts = _gs
