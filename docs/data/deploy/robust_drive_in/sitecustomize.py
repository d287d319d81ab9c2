"""Experiment switches (use with PYTHONPATH=<this folder>): GPCNAV_EXP_ROBUST=R gives the GPC's
check robust_drive_in; GPCNAV_EXP_ROBUST=RT gives it robust_drive_in with the searched way out
in two phases (rule.md). Since RT was adopted (the registry's GPC check), GPCNAV_EXP_ROBUST=OFF
gives the GPC the check it had before: trust_plans and safer_alternatives only.
GPCNAV_EXP_NN_ROBUST=1 gives the deployed network's check (--controller nn) robust_drive_in
(nn_rule.md)."""
import os
import sys

form = os.environ.get("GPCNAV_EXP_ROBUST")
if form in ("R", "RT"):
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig_gpc = C._gpc_check

    def _gpc_check(*a, **kw):
        s = replace(_orig_gpc(*a, **kw), robust_drive_in=True)
        return replace(s, search=True, search_two_phase=True) if form == "RT" else s

    C.REGISTRY["gpc"] = C.Kind(C.REGISTRY["gpc"].default_shield, _gpc_check)
    print(f"GPCNAV_EXP_ROBUST={form}: the GPC's check judges drive-ins against the uncertain discs"
          + (", and searches its way out in two phases" if form == "RT" else ""), file=sys.stderr)

if form == "OFF":
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig_gpc = C._gpc_check

    def _gpc_check_before(*a, **kw):
        return replace(_orig_gpc(*a, **kw), search=False, search_two_phase=False, robust_drive_in=False)

    C.REGISTRY["gpc"] = C.Kind(C.REGISTRY["gpc"].default_shield, _gpc_check_before)
    print("GPCNAV_EXP_ROBUST=OFF: the GPC's check as before 2026-11-28's adoption", file=sys.stderr)

if os.environ.get("GPCNAV_EXP_NN_ROBUST") == "1":
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig_nn = C._nn_check

    def _nn_check(*a, **kw):
        return replace(_orig_nn(*a, **kw), robust_drive_in=True)

    C.REGISTRY["nn"] = C.Kind(C.REGISTRY["nn"].default_shield, _nn_check)
    print("GPCNAV_EXP_NN_ROBUST=1: the deployed network's check judges drive-ins against the uncertain discs",
          file=sys.stderr)
