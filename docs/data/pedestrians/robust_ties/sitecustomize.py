"""Experiment switch (use with PYTHONPATH=<this folder>, run.sh): GPCNAV_EXP_TIES=1 gives the GPC's
check robust_drive_ties (rule.md). Since it was adopted (the registry's GPC check),
GPCNAV_EXP_TIES=0 gives the GPC the check it had before. GPCNAV_EXP_NN_TIES=1 gives the deployed
network's check (--controller nn) robust_drive_ties (nn_rule.md)."""
import os
import sys

if os.environ.get("GPCNAV_EXP_TIES") == "1":
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig_gpc = C._gpc_check

    def _gpc_check(*a, **kw):
        return replace(_orig_gpc(*a, **kw), robust_drive_ties=True)

    C.REGISTRY["gpc"] = C.Kind(C.REGISTRY["gpc"].default_shield, _gpc_check)
    print("GPCNAV_EXP_TIES=1: the GPC's check breaks ties by the drive-in into the uncertain discs", file=sys.stderr)

if os.environ.get("GPCNAV_EXP_TIES") == "0":
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig_gpc0 = C._gpc_check

    def _gpc_check_before(*a, **kw):
        return replace(_orig_gpc0(*a, **kw), robust_drive_ties=False)

    C.REGISTRY["gpc"] = C.Kind(C.REGISTRY["gpc"].default_shield, _gpc_check_before)
    print("GPCNAV_EXP_TIES=0: the GPC's check as before 2026-11-30's adoption", file=sys.stderr)

if os.environ.get("GPCNAV_EXP_NN_TIES") == "1":
    from dataclasses import replace
    from gpcnav import controllers as C
    _orig_nn = C._nn_check

    def _nn_check(*a, **kw):
        return replace(_orig_nn(*a, **kw), robust_drive_ties=True)

    C.REGISTRY["nn"] = C.Kind(C.REGISTRY["nn"].default_shield, _nn_check)
    print("GPCNAV_EXP_NN_TIES=1: the deployed network's check breaks ties by the drive-in into the uncertain discs",
          file=sys.stderr)
