"""Experiment switches (use with PYTHONPATH=<this folder>, run.sh): GPCNAV_EXP_TIES=1 gives the GPC's
check robust_drive_ties (rule.md); since it was adopted (the registry's GPC check), GPCNAV_EXP_TIES=0
gives the GPC the check it had before. GPCNAV_EXP_NN_TIES=1 gives the deployed network's check
(--controller nn) robust_drive_ties (nn_rule.md); since it was adopted, GPCNAV_EXP_NN_TIES=0 takes it
away."""
import os
import sys


def _switch(name: str, check: str, on: bool, what: str) -> None:
    """The registry's controller ``name`` with its check (``check``: the function making its
    settings) given ``robust_drive_ties=on``."""
    from dataclasses import replace
    from gpcnav import controllers as C
    orig = getattr(C, check)

    def settings(*a, **kw):
        return replace(orig(*a, **kw), robust_drive_ties=on)

    C.REGISTRY[name] = C.Kind(C.REGISTRY[name].default_shield, settings)
    print(what, file=sys.stderr)


_FORMS = {("GPCNAV_EXP_TIES", "1"): ("gpc", "_gpc_check", True, "the GPC's check breaks ties by the drive-in into "
                                     "the uncertain discs"),
          ("GPCNAV_EXP_TIES", "0"): ("gpc", "_gpc_check", False, "the GPC's check as before 2026-11-30's adoption"),
          ("GPCNAV_EXP_NN_TIES", "1"): ("nn", "_nn_check", True, "the deployed network's check breaks ties by the "
                                        "drive-in into the uncertain discs"),
          ("GPCNAV_EXP_NN_TIES", "0"): ("nn", "_nn_check", False, "the deployed network's check as before 2026-11-30's "
                                        "adoption")}
for (var, value), (name, check, on, what) in _FORMS.items():
    if os.environ.get(var) == value:
        _switch(name, check, on, f"{var}={value}: {what}")
