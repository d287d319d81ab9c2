import os
if os.environ.get("GPCNAV_EXP_BEYOND"):
    import casadi_gpc.config as C
    C.PRESETS["improved"] = C.PRESETS["improved"].with_overrides(
        beyond_horizon_s=tuple(float(v) for v in os.environ["GPCNAV_EXP_BEYOND"].split(",")))
