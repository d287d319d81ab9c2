"""Experiment switch (use with PYTHONPATH=<this folder>): GPCNAV_EXP_WALLS_SEARCH=1 gives the
GPC's check (--controller gpc) the searched way out in two phases at the decisions where a
wall is within the check's reach, and the shipped check elsewhere (rule.md);
GPCNAV_EXP_WALLS_SEARCH=1S the same search in one phase (rule2.md)."""
import os
import sys

_FORM = os.environ.get("GPCNAV_EXP_WALLS_SEARCH")
if _FORM == "1":
    from dataclasses import replace

    from casadi_gpc.safety.filter import SafetyFilter
    from gpcnav import controllers as C

    _orig_gpc = C._gpc_check

    def _gpc_check(*a, **kw):
        return replace(_orig_gpc(*a, **kw), search=True, search_two_phase=True)

    C.REGISTRY["gpc"] = C.Kind(C.REGISTRY["gpc"].default_shield, _gpc_check)
    _orig_filter = SafetyFilter._filter

    def _filter(self, observation, wheels, forecasts, statics, poses, alternatives, trust_s, previous,
                plan_on_demand, walls):
        if self.trust_plans_gate:  # the GPC's check: search only with a wall within reach
            on = walls is not None and len(walls) > 0
            self.search_way_out = self.search_two_phase = on
        return _orig_filter(self, observation, wheels, forecasts, statics, poses, alternatives, trust_s,
                            previous, plan_on_demand, walls)

    SafetyFilter._filter = _filter
    SafetyFilter.trust_plans_gate = False
    from casadi_gpc.safety import shield as S
    _orig_init = S.Shield.__init__

    def _init(self, *a, **kw):
        _orig_init(self, *a, **kw)
        # the GPC's check (a planner's plans trusted, the search given above) is the one gated
        self.filter.trust_plans_gate = bool(self.trust_plans and self.settings.search)

    S.Shield.__init__ = _init
    print("GPCNAV_EXP_WALLS_SEARCH=1: the GPC's check searches its way out in two phases where a wall is "
          "within reach", file=sys.stderr)

if _FORM == "1S":  # through the option itself (CheckSettings.search_near_walls, tested against the above)
    from dataclasses import replace

    from gpcnav import controllers as C

    _orig_gpc1 = C._gpc_check

    def _gpc_check1(*a, **kw):
        return replace(_orig_gpc1(*a, **kw), search=True, search_near_walls=True)

    C.REGISTRY["gpc"] = C.Kind(C.REGISTRY["gpc"].default_shield, _gpc_check1)
    print("GPCNAV_EXP_WALLS_SEARCH=1S: the GPC's check searches its way out in one phase where a wall is "
          "within reach", file=sys.stderr)
