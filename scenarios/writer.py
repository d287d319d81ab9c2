"""Scenario files written back: a :class:`~scenarios.model.Scenario` as the document the
loader reads (:func:`scenario_document`), and such a document as TOML (:func:`to_toml`).
``load_scenario`` of what these write gives the same scenario (tested)."""
from __future__ import annotations

import math

__all__ = ["scenario_document", "to_toml"]

_ESCAPES = {'"': '\\"', "\\": "\\\\", "\n": "\\n", "\t": "\\t", "\r": "\\r", "\b": "\\b", "\f": "\\f"}


def _escaped(c: str) -> str:
    """One character of a TOML basic string: a quote, a backslash and the control characters
    TOML takes only escaped (U+0000 to U+001F, U+007F) escaped; a description with a line break was
    written as it was, which no TOML reader takes."""
    if c in _ESCAPES:
        return _ESCAPES[c]
    return f"\\u{ord(c):04X}" if ord(c) < 0x20 or ord(c) == 0x7F else c


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(float(v)) if isinstance(v, float) else str(v)
    if isinstance(v, str):
        return '"' + "".join(_escaped(c) for c in v) + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def to_toml(table: dict) -> str:
    """A scenario document (two levels of tables and arrays of tables) as TOML."""
    lines, sub = [], []
    for key, v in table.items():
        if isinstance(v, dict) or isinstance(v, list) and v and isinstance(v[0], dict):
            sub.append((key, v))
        elif not (isinstance(v, list) and not v):
            lines.append(f"{key} = {_value(v)}")
    for key, v in sub:
        for item in (v if isinstance(v, list) else [v]):
            lines += ["", f"[[{key}]]" if isinstance(v, list) else f"[{key}]"]
            nested = []
            for k, x in item.items():
                if isinstance(x, list) and x and isinstance(x[0], dict):
                    nested.append((k, x))
                else:
                    lines.append(f"{k} = {_value(x)}")
            for k, items in nested:
                for it in items:
                    lines += [f"[[{key}.{k}]]"] + [f"{kk} = {_value(xx)}" for kk, xx in it.items()]
    return "\n".join(lines) + "\n"


def _segment(seg) -> dict:
    if seg.curvature_1pm == 0.0:
        return {"line_m": float(seg.length_m)}
    radius = 1.0 / abs(seg.curvature_1pm)
    return {"arc_radius_m": radius, "arc_angle_deg": math.degrees(seg.length_m * seg.curvature_1pm)}


def _mover(m) -> dict:
    if hasattr(m, "track"):
        d = {"radius_m": float(m.radius_m), "behaviour": m.behaviour}
        if m.behaviour != "replay":
            d["sees_robot"] = bool(m.sees_robot)
        d["track"] = [list(row) for row in m.track]
        return d
    if getattr(m, "behaviour", "constant") != "constant":
        return {"position": list(m.position_m), "radius_m": float(m.radius_m), "behaviour": m.behaviour,
                "goal": list(m.goal_m), "preferred_speed_mps": float(m.preferred_speed_mps),
                "sees_robot": bool(m.sees_robot)}
    return {"position": list(m.position_m), "heading_deg": math.degrees(m.heading_rad), "speed_mps": float(m.speed_mps),
            "turn_rate_deg_s": math.degrees(m.turn_rate_rad_s), "radius_m": float(m.radius_m)}


def scenario_document(sc) -> dict:
    """``sc`` as the scenario file's document (robot sizes left to their defaults where they
    are the defaults; faults are not written)."""
    from casadi_gpc.robot import RobotParams
    robot = {"position": [sc.robot_start.x_m, sc.robot_start.y_m], "heading_deg": math.degrees(sc.robot_start.heading_rad)}
    defaults = RobotParams()
    for k in ("wheel_base_m", "radius_m", "max_wheel_speed_mps", "max_wheel_accel_mps2"):
        if getattr(sc.robot, k) != getattr(defaults, k):
            robot[k] = float(getattr(sc.robot, k))
    sensing = {"position_noise_std_m": float(sc.sensing.position_noise_std_m), "seed": int(sc.sensing.seed)}
    if sc.sensing.range_m is not None:
        sensing["range_m"] = float(sc.sensing.range_m)
    doc = {"name": sc.name, "description": sc.description, "duration_s": float(sc.duration_s), "robot": robot,
           "reference": {"position": list(sc.reference.start_xy_m),
                         "heading_deg": math.degrees(sc.reference.start_heading_rad),
                         "speed_mps": float(sc.reference.speed_mps),
                         "segments": [_segment(s) for s in sc.reference.segments]},
           "sensing": sensing,
           "moving_obstacles": [_mover(m) for m in sc.moving],
           "static_obstacles": [{"position": list(s.position_m), "radius_m": float(s.radius_m)} for s in sc.static],
           "walls": [{"points": [list(p) for p in w.points]} for w in sc.walls]}
    return doc
