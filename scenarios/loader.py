"""Reading scenario files (TOML, CONTRACT.md) with strict validation.

Every problem raises :class:`ScenarioError` whose message is one line naming the file,
the field and what is wrong; nothing runs before the whole file has passed.
"""
from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

from casadi_gpc.reference import ReferencePath, Segment
from casadi_gpc.robot import RobotParams, RobotState
from casadi_gpc.types import StaticObstacle

from .model import TRACK_BEHAVIOURS, Faults, MovingObstacleSpec, Scenario, Sensing, TrackSpec, WalkerSpec, Wall

__all__ = ["ScenarioError", "load_scenario", "scenario_from_dict", "BEHAVIOURS"]

_NAME = re.compile(r"[A-Za-z0-9_-]+")  # fullmatch: '$' would pass a trailing line break
LARGEST = 1e9
"""The largest magnitude of a number in a scenario (m, s, degrees, m/s): beyond it a place,
length or time is no scene a robot drives in (map coordinates such as UTM northings, up to
1e7 m, pass), and sums and squares of such numbers overflow to infinity. Integers (a seed)
may be up to 2^63 - 1."""
_LARGEST_INT = 2 ** 63 - 1
SMALLEST_ROBOT_M = 0.01
"""The smallest wheel base and robot radius a file takes: a wheel base of 1e-300 m (taken, as
any positive number was until 2026-12-02) made a turn rate of 1e300 rad/s, and one solve of the
planner's compiled problem never returned; a robot under a centimetre meets a thin wall between
the collision check's instants. Where between the planner stops answering was not measured (each
wheel base compiles its own problem, minutes each); a centimetre is below any robot gpcnav is
likely to drive (a Thymio: 9.4 cm wheel axis, 5.5 cm radius)."""


class ScenarioError(ValueError):
    """A scenario file that cannot be used; the message is one line."""


class _Reader:
    def __init__(self, source: str):
        self.source = source

    def fail(self, field: str, what: str):
        text = f"{self.source}: {field}: {what}"
        if len(text.splitlines()) > 1:  # a key or a path with a line break in it: escaped, one line
            text = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
        raise ScenarioError(text)

    def table(self, data, field: str, allowed: set[str], required: set[str]) -> dict:
        if not isinstance(data, dict):
            self.fail(field, "must be a table")
        for key in data:
            if key not in allowed:
                self.fail(f"{field}.{key}" if field else key, f"unknown key (allowed: {', '.join(sorted(allowed))})")
        for key in sorted(required):
            if key not in data:
                self.fail(f"{field}.{key}" if field else key, "missing required field")
        return data

    def number(self, data: dict, key: str, field: str, *, default=None, positive=False,
               nonnegative=False, integer=False, maximum=None):
        name = f"{field}.{key}" if field else key
        if key not in data:
            if default is None:
                self.fail(name, "missing required field")
            return default
        v = data[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            self.fail(name, f"must be a number, got {type(v).__name__}")
        if integer and not isinstance(v, int):
            self.fail(name, "must be an integer")
        self._bounded(name, v, _LARGEST_INT if integer else LARGEST)
        if positive and not v > 0:
            self.fail(name, f"must be positive, got {v}")
        if nonnegative and v < 0:
            self.fail(name, f"must not be negative, got {v}")
        if maximum is not None and v > maximum:
            self.fail(name, f"must be at most {maximum}, got {v}")
        return v

    def point(self, data: dict, key: str, field: str) -> tuple[float, float]:
        name = f"{field}.{key}" if field else key
        if key not in data:
            self.fail(name, "missing required field")
        v = data[key]
        if not isinstance(v, list) or len(v) != 2:
            self.fail(name, "must be a list of two numbers [x, y]")
        for c in v:
            if isinstance(c, bool) or not isinstance(c, (int, float)):
                self.fail(name, "must be a list of two numbers [x, y]")
            self._bounded(name, c, LARGEST)
        return float(v[0]), float(v[1])

    def _bounded(self, name: str, v, largest) -> None:
        """Refuse a number that is not finite or larger in magnitude than ``largest`` (an
        integer too large for a float included)."""
        if isinstance(v, int) and abs(v) > largest:
            self.fail(name, f"must be at most {largest:g} in magnitude, got about "
                            f"{'-' if v < 0 else ''}10^{int(abs(v).bit_length() * math.log10(2))}")
        if not math.isfinite(v):
            self.fail(name, f"must be finite, got {v}")
        if abs(v) > largest:
            self.fail(name, f"must be at most {largest:g} in magnitude, got {v:g}")

    def rows(self, v, name: str, width: int, plural: str, one: str) -> list:
        """``v`` as a list of at least two rows of ``width`` finite numbers each (a track's
        ``[t, x, y]`` rows, a wall's ``[x, y]`` points), or a one-line refusal."""
        if not isinstance(v, list):
            self.fail(name, f"must be a list of {plural}")
        if len(v) < 2:
            self.fail(name, f"needs at least two {plural.split()[-1]}, got {len(v)}")
        for k, row in enumerate(v):
            if not isinstance(row, list) or len(row) != width or any(
                    isinstance(c, bool) or not isinstance(c, (int, float)) for c in row):
                self.fail(f"{name}[{k}]", f"must be {one}")
            for c in row:
                self._bounded(f"{name}[{k}]", c, LARGEST)
        return v

    def array_of_tables(self, data: dict, key: str) -> list:
        v = data.get(key, [])
        if not isinstance(v, list) or not all(isinstance(t, dict) for t in v):
            self.fail(key, "must be an array of tables ([[...]])")
        return v


_TOP_KEYS = {"name", "description", "duration_s", "robot", "reference", "moving_obstacles", "static_obstacles",
             "sensing", "faults", "walls"}
_CONSTANT_KEYS = {"position", "heading_deg", "speed_mps", "turn_rate_deg_s", "radius_m", "behaviour"}
_WALKER_KEYS = {"position", "radius_m", "behaviour", "goal", "preferred_speed_mps", "sees_robot"}
_TRACK_KEYS = {"track", "radius_m", "behaviour", "sees_robot"}
BEHAVIOURS = ("constant", "orca", "social_force")
"""What a moving obstacle may do: keep its course, or walk to a goal (scenarios.movers)."""


def scenario_from_dict(data: dict, source: str = "<scenario>") -> Scenario:
    """Validate a parsed scenario document and build the :class:`Scenario`."""
    r = _Reader(source)
    r.table(data, "", _TOP_KEYS, {"name", "duration_s", "robot", "reference"})
    name = data["name"]
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        r.fail("name", "must be a string of ASCII letters, digits, '_' and '-' (it names files and episodes)")
    description = data.get("description", "")
    if not isinstance(description, str):
        r.fail("description", "must be a string")
    duration = float(r.number(data, "duration_s", "", positive=True))
    params, start = _robot(r, data["robot"])
    reference = _reference(r, data["reference"], params)
    moving = [_moving(r, ob, f"moving_obstacles[{i}]") for i, ob in enumerate(r.array_of_tables(data, "moving_obstacles"))]
    static = [_static(r, ob, f"static_obstacles[{i}]") for i, ob in enumerate(r.array_of_tables(data, "static_obstacles"))]
    walls = [_wall(r, w, f"walls[{i}]") for i, w in enumerate(r.array_of_tables(data, "walls"))]
    sensing = _sensing(r, data["sensing"]) if "sensing" in data else Sensing()
    faults = _faults(r, data["faults"]) if "faults" in data else Faults()
    for kind, obstacles in (("moving_obstacles", moving), ("static_obstacles", static)):
        for i, ob in enumerate(obstacles):
            if isinstance(ob, TrackSpec) and not ob.exists_at(0.0):
                continue  # someone who enters the scene later
            if isinstance(ob, TrackSpec):
                x, y = ob.recorded_at(0.0)
                gap = math.hypot(x - start.x_m, y - start.y_m) - params.radius_m - ob.radius_m
                if gap < 0:
                    r.fail(f"{kind}[{i}].track", f"the robot starts overlapping this mover (gap {gap:.3f} m)")
                continue
            gap = math.hypot(ob.position_m[0] - start.x_m, ob.position_m[1] - start.y_m) - params.radius_m - ob.radius_m
            if gap < 0:
                r.fail(f"{kind}[{i}].position", f"the robot starts overlapping this obstacle (gap {gap:.3f} m)")
    for i, w in enumerate(walls):
        gap = float(w.distance_m((start.x_m, start.y_m))) - params.radius_m
        if gap <= 0:
            r.fail(f"walls[{i}].points", f"the robot starts touching this wall (gap {gap:.3f} m)")
    return Scenario(name, duration, start, reference, params, tuple(moving), tuple(static), sensing, faults,
                    description, source, tuple(walls))


def _robot(r: _Reader, table) -> tuple[RobotParams, RobotState]:
    rob = r.table(table, "robot", {"position", "heading_deg", "wheel_base_m", "radius_m", "max_wheel_speed_mps",
                                   "max_wheel_accel_mps2"}, {"position", "heading_deg"})
    defaults = RobotParams()
    values = {k: float(r.number(rob, k, "robot", default=getattr(defaults, k), positive=True))
              for k in ("wheel_base_m", "radius_m", "max_wheel_speed_mps", "max_wheel_accel_mps2")}
    for k in ("wheel_base_m", "radius_m"):
        if values[k] < SMALLEST_ROBOT_M:
            r.fail(f"robot.{k}", f"must be at least {SMALLEST_ROBOT_M} m, got {values[k]:g} (no robot is smaller "
                                 f"than a centimetre; a wheel base of 1e-300 m stalled the planner's solver)")
    params = RobotParams(**values)
    rx, ry = r.point(rob, "position", "robot")
    return params, RobotState(rx, ry, math.radians(r.number(rob, "heading_deg", "robot")))


def _segment(r: _Reader, seg, f: str) -> Segment:
    r.table(seg, f, {"line_m", "arc_radius_m", "arc_angle_deg"}, set())
    if "line_m" in seg:
        if set(seg) != {"line_m"}:
            r.fail(f, "a segment is either line_m or arc_radius_m with arc_angle_deg, not both")
        return Segment.line(r.number(seg, "line_m", f, positive=True))
    if set(seg) == {"arc_radius_m", "arc_angle_deg"}:
        radius = r.number(seg, "arc_radius_m", f, positive=True)
        angle = r.number(seg, "arc_angle_deg", f)
        if angle == 0:
            r.fail(f"{f}.arc_angle_deg", "must not be 0")
        return Segment.arc(radius, math.radians(angle))
    r.fail(f, "needs line_m, or arc_radius_m and arc_angle_deg")


def _reference(r: _Reader, table, params: RobotParams) -> ReferencePath:
    ref = r.table(table, "reference", {"position", "heading_deg", "speed_mps", "segments"},
                  {"position", "heading_deg", "speed_mps", "segments"})
    segs_raw = ref["segments"]
    if not isinstance(segs_raw, list) or not all(isinstance(t, dict) for t in segs_raw):
        r.fail("reference.segments", "must be an array of tables ([[reference.segments]])")
    if not segs_raw:
        r.fail("reference.segments", "the path is empty (give at least one segment)")
    segments = [_segment(r, seg, f"reference.segments[{i}]") for i, seg in enumerate(segs_raw)]
    speed = float(r.number(ref, "speed_mps", "reference", positive=True))
    reachable = params.max_wheel_speed_mps / max(
        [1.0] + [1.0 + 0.5 * params.wheel_base_m * abs(s.curvature_1pm) for s in segments])
    if speed > reachable + 1e-12:
        r.fail("reference.speed_mps", f"{speed} m/s is above what the wheels can reach on this path "
                                      f"({reachable:.3f} m/s with max_wheel_speed_mps {params.max_wheel_speed_mps})")
    return ReferencePath(r.point(ref, "position", "reference"), math.radians(r.number(ref, "heading_deg", "reference")),
                         tuple(segments), speed)


def _moving(r: _Reader, ob, f: str) -> MovingObstacleSpec | WalkerSpec | TrackSpec:
    """One ``[[moving_obstacles]]`` table: a constant mover, a walker (``behaviour``
    ``orca`` or ``social_force``), or a mover that follows a recorded ``track``; each refuses
    the others' keys."""
    if isinstance(ob, dict) and "track" in ob:
        return _track_mover(r, ob, f)
    behaviour = ob.get("behaviour", "constant") if isinstance(ob, dict) else "constant"
    if behaviour == "replay":  # (it said: must be one of constant, orca, social_force)
        r.fail(f"{f}.behaviour", "'replay' replays a recording: it needs a track = [[t_s, x_m, y_m], ...]")
    if behaviour not in BEHAVIOURS:
        r.fail(f"{f}.behaviour", f"must be one of {', '.join(BEHAVIOURS)}, got {behaviour!r}")
    own, other = (_CONSTANT_KEYS, _WALKER_KEYS) if behaviour == "constant" else (_WALKER_KEYS, _CONSTANT_KEYS)
    for key in sorted(other - own):
        if isinstance(ob, dict) and key in ob:
            r.fail(f"{f}.{key}", f"not for a mover with behaviour {behaviour!r} (one way to say one thing: "
                                 f"{'a walker starts towards its goal' if behaviour != 'constant' else 'a constant mover has no goal'})")
    every = _CONSTANT_KEYS | _WALKER_KEYS | _TRACK_KEYS
    unknown = sorted(k for k in ob if k not in every) if isinstance(ob, dict) else []
    if unknown:  # the keys of every kind of mover: a misspelt 'track' was told a constant mover's alone
        walker = ", ".join(sorted(_WALKER_KEYS - _CONSTANT_KEYS))
        r.fail(f"{f}.{unknown[0]}", f"unknown key (a mover takes {', '.join(sorted(_CONSTANT_KEYS))}; a walker, "
                                    f"behaviour orca or social_force: {walker}; a recorded one: track, sees_robot)")
    if behaviour == "constant":
        r.table(ob, f, _CONSTANT_KEYS, {"position", "heading_deg", "speed_mps", "radius_m"})
        return MovingObstacleSpec(
            r.point(ob, "position", f), math.radians(r.number(ob, "heading_deg", f)),
            float(r.number(ob, "speed_mps", f, nonnegative=True)), float(r.number(ob, "radius_m", f, positive=True)),
            math.radians(r.number(ob, "turn_rate_deg_s", f, default=0.0)))
    r.table(ob, f, _WALKER_KEYS, {"position", "radius_m", "goal", "preferred_speed_mps"})
    sees = ob.get("sees_robot", False)
    if not isinstance(sees, bool):
        r.fail(f"{f}.sees_robot", f"must be true or false, got {type(sees).__name__}")
    return WalkerSpec(r.point(ob, "position", f), float(r.number(ob, "radius_m", f, positive=True)), behaviour,
                      r.point(ob, "goal", f), float(r.number(ob, "preferred_speed_mps", f, positive=True)), sees)


def _track_mover(r: _Reader, ob: dict, f: str) -> TrackSpec:
    """A mover with a ``track`` of ``[t_s, x_m, y_m]`` rows (CONTRACT.md, "Movers that follow
    a recording")."""
    for key in sorted(set(ob) - _TRACK_KEYS):
        if key in _CONSTANT_KEYS | _WALKER_KEYS:
            r.fail(f"{f}.{key}", "not for a mover with a track (it follows its recording: one way to say one thing)")
    r.table(ob, f, _TRACK_KEYS, {"track", "radius_m"})
    behaviour = ob.get("behaviour", "replay")
    if behaviour not in TRACK_BEHAVIOURS:
        r.fail(f"{f}.behaviour", f"with a track must be one of {', '.join(TRACK_BEHAVIOURS)}, got {behaviour!r}")
    sees = ob.get("sees_robot", False)
    if not isinstance(sees, bool):
        r.fail(f"{f}.sees_robot", f"must be true or false, got {type(sees).__name__}")
    if sees and behaviour == "replay":
        r.fail(f"{f}.sees_robot", "a replayed track cannot give way (sees_robot is for orca and social_force)")
    name = f"{f}.track"
    out = []
    for k, row in enumerate(r.rows(ob["track"], name, 3, "[t_s, x_m, y_m] rows", "a row of three numbers [t_s, x_m, y_m]")):
        if row[0] < 0:
            r.fail(f"{name}[{k}]", f"time must not be negative, got {row[0]}")
        if out and not row[0] > out[-1][0]:
            r.fail(f"{name}[{k}]", f"times must increase strictly ({row[0]} after {out[-1][0]})")
        out.append((float(row[0]), float(row[1]), float(row[2])))
    return TrackSpec(float(r.number(ob, "radius_m", f, positive=True)), tuple(out), behaviour, sees)


def _wall(r: _Reader, table, f: str) -> Wall:
    """One ``[[walls]]`` table: a polyline of at least two points, no segment of zero length."""
    r.table(table, f, {"points"}, {"points"})
    name = f"{f}.points"
    out = []
    for k, pt in enumerate(r.rows(table["points"], name, 2, "[x, y] points", "a point of two numbers [x, y]")):
        if out and math.hypot(pt[0] - out[-1][0], pt[1] - out[-1][1]) == 0.0:
            r.fail(f"{name}[{k}]", "a segment of zero length (the same point twice in a row)")
        out.append((float(pt[0]), float(pt[1])))
    return Wall(tuple(out))


def _static(r: _Reader, ob, f: str) -> StaticObstacle:
    r.table(ob, f, {"position", "radius_m"}, {"position", "radius_m"})
    return StaticObstacle(r.point(ob, "position", f), float(r.number(ob, "radius_m", f, positive=True)))


def _sensing(r: _Reader, table) -> Sensing:
    s = r.table(table, "sensing", {"position_noise_std_m", "seed", "range_m"}, set())
    range_m = r.number(s, "range_m", "sensing", positive=True) if "range_m" in s else None
    return Sensing(float(r.number(s, "position_noise_std_m", "sensing", default=0.02, nonnegative=True)),
                   int(r.number(s, "seed", "sensing", default=0, integer=True, nonnegative=True)),
                   None if range_m is None else float(range_m))


def _faults(r: _Reader, table) -> Faults:
    s = r.table(table, "faults", {"dropout_prob", "outlier_prob", "outlier_distance_m", "delay_steps",
                                  "solver_failure_prob"}, set())
    return Faults(
        float(r.number(s, "dropout_prob", "faults", default=0.0, nonnegative=True, maximum=1.0)),
        float(r.number(s, "outlier_prob", "faults", default=0.0, nonnegative=True, maximum=1.0)),
        float(r.number(s, "outlier_distance_m", "faults", default=3.0, positive=True)),
        int(r.number(s, "delay_steps", "faults", default=0, integer=True, nonnegative=True)),
        float(r.number(s, "solver_failure_prob", "faults", default=0.0, nonnegative=True, maximum=1.0)),
    )


def faults_from_table(table: dict, source: str) -> Faults:
    """A ``[faults]`` table (``evaluate --faults`` as well as a file's) checked as a file's
    is: one :class:`ScenarioError` line naming ``source`` and the field."""
    return _faults(_Reader(source), table)


def load_scenario(path) -> Scenario:
    """Read and validate a scenario file; raises :class:`ScenarioError` with one line."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")  # past a byte-order mark (Windows editors write one)
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"{path}: cannot read the file ({exc.__class__.__name__}: {exc})") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML ({exc})".replace("\n", " ")) from None
    return scenario_from_dict(data, str(path))
