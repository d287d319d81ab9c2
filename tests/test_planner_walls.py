"""The planner's NLP and walls: wall-segment slots only where a run has walls, the penalty at
the segment's nearest point (the same as a static disc of no radius there), the nearest
segments chosen, and no fixed guess through a wall."""
from __future__ import annotations

import tomllib

import numpy as np
import pytest

casadi = pytest.importorskip("casadi")

from casadi_gpc.config import WALL_SLOTS, preset  # noqa: E402
from conftest import straight_line_toml  # noqa: E402
from casadi_gpc.planner.guesses import meets_walls, meets_walls_reference  # noqa: E402
from casadi_gpc.problem.cost import ParameterLayout, build_problem  # noqa: E402
from casadi_gpc.problem.selection import select_walls  # noqa: E402
from casadi_gpc.robot import RobotParams  # noqa: E402
from casadi_gpc.types import StaticObstacle  # noqa: E402
from gpcnav.commands.common import for_run, with_wall_slots  # noqa: E402
from scenarios import scenario_from_dict  # noqa: E402

CFG = preset("improved")


def test_a_run_without_walls_keeps_its_nlp():
    assert CFG.max_walls == 0 and preset("paper").max_walls == 0
    assert ParameterLayout(12, 10, 3).size == ParameterLayout(12, 10, 3, 0).size
    assert "wall_ab" not in ParameterLayout(12, 10, 3).blocks
    plain = scenario_from_dict(tomllib.loads(BASE), "t")
    walled = scenario_from_dict(tomllib.loads(BASE + "[[walls]]\npoints = [[-1.0, 1.2], [9.0, 1.2]]\n"), "t")
    assert with_wall_slots(CFG, [plain]) is CFG
    assert with_wall_slots(CFG, [plain, walled]).max_walls == WALL_SLOTS
    assert CFG.for_walls(False) is CFG and CFG.for_walls(True).for_walls(True).max_walls == WALL_SLOTS


BASE = straight_line_toml("w", 30.0, 6.0)


def test_a_wall_costs_what_a_static_point_costs_at_its_nearest_point():
    """The same robot path, priced once with a wall segment and once with a static obstacle of
    no radius at the segment's point nearest each state: the obstacle terms agree (the wall's
    nearest point moves with the robot, so the comparison is made one state at a time)."""
    cfg = CFG.with_overrides(horizon=1, max_walls=1, max_moving=1, max_static=1)
    prob = build_problem(cfg, RobotParams())
    x0 = np.array([0.0, 0.0, 0.0, 0.3, 0.3])
    ref = np.array([[0.2, 0.0, 0.0]])
    u = np.array([0.05, 0.02])
    wall = [(1.0, -1.0, 1.0, 2.0)]
    pw = prob.layout.pack(x0, ref, walls=wall)
    poses = np.asarray(prob.rollout_fn(u, pw)[0]).reshape(-1, 3)
    nearest = (1.0, float(np.clip(poses[0, 1], -1.0, 2.0)))
    ps = prob.layout.pack(x0, ref, statics=[StaticObstacle(nearest, 1e-9)])
    tw, ts = prob.terms_fn(u, pw), prob.terms_fn(u, ps)
    assert float(tw[3]) == pytest.approx(float(ts[3]), rel=1e-6)       # obstacle term
    assert float(tw[4]) == pytest.approx(float(ts[4]), rel=1e-6, abs=1e-12)  # margin term
    assert float(tw[3]) > 0.0


def test_the_nearest_segments_fill_the_slots_and_the_rest_are_counted():
    cfg = CFG.with_overrides(max_walls=2)
    walls = (((0.0, 1.0), (10.0, 1.0), (10.0, 5.0)), ((0.0, -1.0), (10.0, -1.0)), ((30.0, 0.0), (31.0, 0.0)))
    chosen, left_out = select_walls(np.zeros(5), walls, cfg)
    assert sorted(chosen) == sorted([(0.0, 1.0, 10.0, 1.0), (0.0, -1.0, 10.0, -1.0)])
    assert left_out == 0
    chosen, left_out = select_walls(np.zeros(5), walls, CFG.with_overrides(max_walls=1))
    assert len(chosen) == 1 and left_out == 1        # the other 1 m away is relevant and left out


def test_a_guess_through_a_wall_or_onto_one_is_known():
    robot = RobotParams()
    x0 = np.array([0.0, 0.0, 0.0, 0.4, 0.4])
    straight = np.zeros(2 * CFG.horizon)            # 0.4 m/s for 6 s: to x = 2.4
    assert meets_walls(CFG, robot, x0, straight, [(2.0, -1.0, 2.0, 1.0)])
    assert not meets_walls(CFG, robot, x0, straight, [(3.0, -1.0, 3.0, 1.0)])
    assert not meets_walls(CFG, robot, x0, straight, [(0.0, 1.0, 5.0, 1.0)])
    # not crossed, but its disc (0.35 m) would touch it: 0.2 m beyond the path's end
    assert meets_walls(CFG, robot, x0, straight, [(2.6, -1.0, 2.6, 1.0)])
    # a robot already nearer a wall than its radius is not held to more than keeping its distance
    along = [(0.0, 0.3, 5.0, 0.3)]
    assert not meets_walls(CFG, robot, x0, straight, along)
    assert meets_walls(CFG, robot, x0, np.tile([0.02, 0.0], CFG.horizon), along)  # turning left into it


def test_the_compiled_test_of_a_guess_answers_as_numpy_s_geometry():
    """:func:`meets_walls` (one compiled call) against :func:`meets_walls_reference` (the robot
    model's float form and numpy's segment geometry) on random states, guesses and walls: walls
    crossing the path, along it at the robot's radius, segments of no length."""
    robot, rng = RobotParams(), np.random.default_rng(5)
    met = 0
    for trial in range(3000):
        x0 = np.concatenate([rng.uniform(-3, 3, 2), rng.uniform(-4, 4, 1), rng.uniform(-0.8, 0.8, 2)])
        u = rng.normal(0.0, 0.15, 2 * CFG.horizon)
        seg = rng.uniform(-4, 4, (int(rng.integers(1, 6)), 4))
        if trial % 7 == 0:
            seg[:, 2:] = seg[:, :2]
        if trial % 11 == 0:
            seg[0, 1] = seg[0, 3] = x0[1] + rng.choice([0.35, 0.5, 1.0])
        want = meets_walls_reference(CFG, robot, x0, u, seg)
        assert meets_walls(CFG, robot, x0, u, seg) == want, trial
        met += want
    assert 300 < met < 2700  # both answers are exercised


def test_the_planner_keeps_off_a_wall_it_is_driven_at():
    """A corridor that narrows: the reference runs 0.2 m from a wall that juts in; with the
    wall in its NLP the GPC (bare, no check layer) keeps its disc off it."""
    from casadi_gpc.planner.gpc import GPCController
    from scenarios.simulator import simulate
    sc = scenario_from_dict(tomllib.loads(BASE + "[[walls]]\npoints = [[2.0, 0.55], [4.0, 0.55]]\n"), "t")
    log = simulate(sc, GPCController(for_run(CFG, [sc]), sc.robot))  # as the command line configures it
    assert log.outcome == "reached_goal" and log.min_clearance_m > 0.05
    blind = simulate(sc, GPCController(CFG.for_movers(len(sc.moving)), sc.robot))
    assert blind.min_clearance_m < log.min_clearance_m


def test_the_cost_s_nearest_wall_point_is_the_geometry_s():
    """The cost writes the segment's nearest point in CasADi (casadi_gpc.problem.cost); the
    world and the robot's numpy side use casadi_gpc.geometry.nearest_on_segments. On oblique
    segments, with the nearest point inside and at either end, the cost of the wall is the
    cost of a point obstacle of no radius at the geometry's nearest point."""
    from casadi_gpc.geometry import nearest_on_segments
    cfg = CFG.with_overrides(horizon=1, max_walls=1, max_moving=1, max_static=1)
    prob = build_problem(cfg, RobotParams())
    x0 = np.array([0.0, 0.0, 0.3, 0.3, 0.3])
    ref = np.array([[0.2, 0.0, 0.0]])
    u = np.array([0.04, -0.02])
    rng = np.random.default_rng(5)
    ends = set()
    for _ in range(40):
        a = rng.uniform(-1.5, 1.5, 2)
        b = a + rng.uniform(-2.0, 2.0, 2)
        pw = prob.layout.pack(x0, ref, walls=[(*a, *b)])
        xy = np.asarray(prob.rollout_fn(u, pw)[0]).reshape(-1, 3)[0, :2]
        point = nearest_on_segments(xy, a[None], b[None])[0]
        ends.add(int(np.allclose(point, a)) - int(np.allclose(point, b)))
        ps = prob.layout.pack(x0, ref, statics=[StaticObstacle(tuple(point), 1e-9)])
        tw, ts = prob.terms_fn(u, pw), prob.terms_fn(u, ps)
        assert float(tw[3]) == pytest.approx(float(ts[3]), rel=1e-6)
        assert float(tw[4]) == pytest.approx(float(ts[4]), rel=1e-6, abs=1e-12)
    assert ends == {-1, 0, 1}  # inside, and at each end, all met


def test_in_a_corridor_the_sideways_guesses_are_narrowed_to_fit_and_counted():
    """In a 2.5 m corridor the full swerves and the 1.5 m detours meet a wall: each is made
    narrower until it keeps off them (so the robot still has a cold guess to either side),
    and what nothing narrows (straight on, into a wall across the way) is left out. With one
    cold start a tick (the ``improved`` preset) a guess left out gives its turn to the next
    of the queue, so a tick still solves one."""
    from casadi_gpc.planner.gpc import GPCController
    from casadi_gpc.planner.guesses import initial_guesses
    from scenarios.simulator import Episode
    walls = ("[[walls]]\npoints = [[-1.0, 1.25], [30.0, 1.25]]\n"
             "[[walls]]\npoints = [[-1.0, -1.25], [30.0, -1.25]]\n")
    sc = scenario_from_dict(tomllib.loads(BASE + walls), "corridor")
    ctl = GPCController(for_run(CFG, [sc]), sc.robot)
    obs = Episode(sc, CFG.sample_time_s).observation()
    tick, _ = ctl.pose(obs, ctl.estimate(obs))
    segs = ctl._walls_in_slots
    assert len(segs) == 2
    full = initial_guesses(ctl.problem, tick.x0, 0.4, np.asarray(tick.p[ctl._ref_slice]).reshape(-1, 3))
    met = {n for n, u in full.items() if meets_walls(CFG, ctl.robot, tick.x0, u, segs)}
    assert {"swerve_right", "swerve_left", "detour_right", "detour_left"} <= met
    starts = ctl._guess_starts(tick.p, tick.x0, 0.4)
    names = [s[0] for s in starts]
    assert names == ["swerve_right", "swerve_left", "straight", "detour_right", "detour_left", "brake"]
    for name, u0, _, _ in starts:
        assert not meets_walls(CFG, ctl.robot, tick.x0, u0, segs), name
    assert ctl.counters["guesses_narrowed"] == 4 and ctl.counters["guesses_through_walls"] == 0
    # a wall across the way 2 m ahead: straight on (0.4 m/s for 6 s) meets it, no narrowing helps
    ctl._walls_in_slots = segs + [(2.0, -1.25, 2.0, 1.25)]
    names = [s[0] for s in ctl._guess_starts(tick.p, tick.x0, 0.4)]
    assert "straight" not in names and ctl.counters["guesses_through_walls"] >= 1
    # one guess a tick: the queue's straight is left out, and the next guess is solved instead
    ctl._pending = ["detour_right", "brake", "swerve_left"]
    batch = ["straight"]
    got = ctl._queued_starts(tick.p, tick.x0, 0.4, batch, keep_one=False)
    assert [s[0] for s in got] == ["brake"] and batch == ["straight", "detour_right", "brake"]
    assert ctl._pending == ["swerve_left"]


def test_a_robot_that_starts_against_a_wall_moves_off_at_once():
    """The robot 0.03 m from a corridor's wall, facing it, no one else in the scene: the GPC
    behind its check (as ``--controller gpc`` runs it) is moving by its second sample and
    reaches its goal. Its first tick solves one fixed guess, which can converge through the
    wall; a kept plan through a wall begins the other guesses (``multistart_through_a_wall``)
    where, with no one near, the queue used to be dropped and the robot stood 10-15 s
    (docs/buildings.md, "A robot that starts against a wall")."""
    from gpcnav.controllers import ControllerSpec, make
    from scenarios.simulator import simulate
    walls = "[[walls]]\npoints = [[-3.0, 1.25], [12.0, 1.25]]\n[[walls]]\npoints = [[-3.0, -1.25], [12.0, -1.25]]\n"
    doc = tomllib.loads(straight_line_toml("against", 40.0, 8.0, walls))
    for heading in (90.0, 150.0):
        doc["robot"] = {"position": [0.0, 1.25 - 0.35 - 0.03], "heading_deg": heading}
        sc = scenario_from_dict(doc, "t")
        cfg = for_run(CFG, [sc])
        log = simulate(sc, make(ControllerSpec("gpc"), cfg, sc.robot), "gpc")
        xy = np.asarray(log.states)[:, :2]
        moved = next(k for k in range(1, len(xy)) if np.hypot(*(xy[k] - xy[0])) > 0.05)
        assert log.outcome == "reached_goal" and moved <= 3, (heading, moved)
        assert len(log.decisions) <= 48, (heading, len(log.decisions))  # stood for 10-15 s before: 51-63


def _scene_at(dx: float, dy: float) -> str:
    """A corridor with a person coming the other way and a pillar, everything moved by (dx, dy)."""
    return f"""
name = "far_{int(dx)}"
duration_s = 20.0
[robot]
position = [{dx}, {dy}]
heading_deg = 0.0
[reference]
position = [{dx}, {dy}]
heading_deg = 0.0
speed_mps = 0.4
[[reference.segments]]
line_m = 5.0
[[moving_obstacles]]
position = [{dx + 5.0}, {dy + 0.3}]
heading_deg = 180.0
speed_mps = 0.3
radius_m = 0.3
[[static_obstacles]]
position = [{dx + 2.5}, {dy - 0.9}]
radius_m = 0.2
[[walls]]
points = [[{dx - 2.0}, {dy + 1.25}], [{dx + 8.0}, {dy + 1.25}]]
[[walls]]
points = [[{dx - 2.0}, {dy - 1.25}], [{dx + 8.0}, {dy - 1.25}]]
[sensing]
position_noise_std_m = 0.0
"""


def test_a_scene_far_from_the_map_s_origin_is_planned_as_at_it():
    """In map coordinates of a few thousand kilometres (UTM's 5e6 m) the NLP read positions of
    that size: its SQP failed starts, the decisions took three times as long (twenty times at
    1e8 m). It is posed in a frame near the robot now (casadi_gpc.problem.cost.frame_origin): the
    same scene gives the same path, moved, to within the positions' rounding, and no more solves."""
    from casadi_gpc.planner.gpc import GPCController
    from casadi_gpc.problem.cost import frame_origin, to_world
    from scenarios.simulator import simulate
    assert not frame_origin(np.array([499.0, -499.0])).any() and list(frame_origin([5e6 + 12.0, -3e6])) == [5e6, -3e6]
    poses = np.array([[1.0, 2.0, 0.3]])
    assert to_world(poses, np.array([3.0, 4.0])) is poses  # near the origin: the same array, bit for bit
    runs = {}
    for dx, dy in ((0.0, 0.0), (5e6, 4e6), (1e8, -1e8)):
        sc = scenario_from_dict(tomllib.loads(_scene_at(dx, dy)), "t")
        cfg = for_run(CFG, [sc])
        ctl = GPCController(cfg, sc.robot)
        log = simulate(sc, ctl)
        xy = np.array([s[:2] for s in log.states]) - (dx, dy)
        runs[dx] = (log.outcome, xy, ctl.counters.get("backup_solves", 0), ctl.counters.get("fallbacks", 0))
    outcome, xy, backups, fallbacks = runs[0.0]
    assert outcome == "reached_goal"
    for dx in (5e6, 1e8):
        o, far_xy, b, f = runs[dx]
        assert (o, b, f) == (outcome, backups, fallbacks)
        assert len(far_xy) == len(xy) and np.max(np.abs(far_xy - xy)) < 1e-6 * max(1.0, dx / 1e8)


def test_a_straight_wall_fills_one_slot_however_many_pieces_it_is_drawn_in():
    """A map's straight wall drawn in 0.25 m pieces (as mapping tools write them) is the same wall
    as one segment: it filled the six slots with the 1.5 m of pieces nearest the path, and priced
    every joint as two walls. The GPC drove otherwise from t = 0.5 s in a corridor with a head-on
    walker (smallest clearance 0.06 against 0.12 m, 20 interventions of the check, 5 of them
    manoeuvres, against none). Now the slots hold the straight runs, and the robot drives the same to
    the bit. A wall that turns keeps its corner."""
    from casadi_gpc.planner.gpc import GPCController
    from scenarios.simulator import simulate
    cfg = CFG.with_overrides(max_walls=2)
    pieces = (tuple((0.25 * i, 1.0) for i in range(41)), ((0.0, -1.0), (5.0, -1.0), (10.0, -1.0), (10.0, 4.0)))
    chosen, left_out = select_walls(np.zeros(5), pieces, cfg)
    assert sorted(chosen) == sorted([(0.0, 1.0, 10.0, 1.0), (0.0, -1.0, 10.0, -1.0)]) and left_out == 0
    walker = "[[moving_obstacles]]\nposition = [7.0, 0.0]\nheading_deg = 180.0\nspeed_mps = 0.3\nradius_m = 0.3\n"
    runs = []
    drawn = [[-5.0 + 0.25 * i, 1.25] for i in range(121)], [[-5.0 + 0.25 * i, -1.25] for i in range(121)]
    for top, bottom in (([[-5.0, 1.25], [25.0, 1.25]], [[-5.0, -1.25], [25.0, -1.25]]), drawn):
        text = straight_line_toml("w", 3.0, 8.0, walker + f"[[walls]]\npoints = {top}\n[[walls]]\npoints = {bottom}\n")
        sc = scenario_from_dict(tomllib.loads(text), "t")
        runs.append(np.asarray(simulate(sc, GPCController(for_run(CFG, [sc]), sc.robot)).states))
    assert np.array_equal(runs[0], runs[1])
