"""Experiment switch (use with PYTHONPATH=<this folder>): the GPC's check (--controller gpc)
searching its way out only at the decisions where a wall is within the check's reach
(CheckSettings.search_near_walls), the shipped check elsewhere. GPCNAV_EXP_WALLS_SEARCH=1: in
two phases (W, rule.md); =1S: in one phase (S, rule2.md).

W's runs in runs/ were made before the option existed, by a switch that set the filter's
search flags at each check from the walls it was handed: the same gate, verdict for verdict
(tests/test_safety.py), and the same records on 30 corner episodes of seed 7 run both ways."""
import os
import sys

_FORM = os.environ.get("GPCNAV_EXP_WALLS_SEARCH")
if _FORM in ("1", "1S"):
    from dataclasses import replace

    from gpcnav import controllers as C

    _orig_gpc = C._gpc_check

    def _gpc_check(*a, **kw):
        return replace(_orig_gpc(*a, **kw), search=True, search_two_phase=_FORM == "1", search_near_walls=True)

    C.REGISTRY["gpc"] = C.Kind(C.REGISTRY["gpc"].default_shield, _gpc_check)
    print(f"GPCNAV_EXP_WALLS_SEARCH={_FORM}: the GPC's check searches its way out in "
          f"{'two phases' if _FORM == '1' else 'one phase'} where a wall is within reach", file=sys.stderr)
