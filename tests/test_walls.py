"""Walls in the world (CONTRACT.md, "Walls"): the format and its refusals, the collision
check against the polyline, walkers that avoid walls (navground's line obstacles), the RUN
document and the plots. The controllers' side of walls is not here yet (issue: walls)."""
from __future__ import annotations

import tomllib

import numpy as np
import pytest

from casadi_gpc.types import ControlDecision
from conftest import assert_refused_in_one_line, straight_line_toml
from gpcnav.cli import main
from scenarios import scenario_from_dict
from scenarios.metrics import run_document
from scenarios.model import Wall
from scenarios.simulator import Episode, simulate

BASE = straight_line_toml("walls", 20.0, 6.0)


class _Drive:
    """Straight ahead at 0.4 m/s, blind."""
    sample_time_s = 0.5

    def reset(self):
        pass

    def decide(self, obs):
        r = obs.robot
        return ControlDecision(min(r.v_right_mps + 0.4, 0.4), min(r.v_left_mps + 0.4, 0.4))


BAD = {
    "one point": ("points = [[1.0, 1.0]]", "needs at least two points"),
    "zero-length segment": ("points = [[1.0, 1.0], [2.0, 1.0], [2.0, 1.0]]", "zero length"),
    "non-finite": ("points = [[1.0, 1.0], [nan, 2.0]]", "must be finite"),
    "a point of three": ("points = [[1.0, 1.0, 0.0], [2.0, 1.0]]", "two numbers"),
    "not a list": ('points = "a wall"', "list of [x, y] points"),
    "unknown key": ("points = [[1.0, 1.0], [2.0, 1.0]]\nthickness_m = 0.1", "unknown key"),
    "robot on the wall": ("points = [[-1.0, 0.2], [1.0, 0.2]]", "starts touching this wall"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_wall_refused_in_one_line_with_exit_2(case, tmp_path, capsys):
    body, words = BAD[case]
    f = tmp_path / "bad.toml"
    f.write_text(BASE + "[[walls]]\n" + body + "\n")
    assert_refused_in_one_line(f, words, capsys)


def test_distance_to_a_polyline_is_exact():
    w = Wall(((0.0, 0.0), (4.0, 0.0), (4.0, 3.0)))
    assert np.allclose(w.distance_m([(2.0, 1.0), (5.0, 1.0), (-1.0, -1.0), (4.0, 4.0)]), [1.0, 1.0, 2 ** 0.5, 1.0])
    assert np.allclose(w.nearest_point((2.0, -3.0)), (2.0, 0.0))


def test_driving_into_a_wall_is_a_collision_with_the_wall_at_the_right_time():
    sc = scenario_from_dict(tomllib.loads(BASE + "[[walls]]\npoints = [[3.0, -2.0], [3.0, 2.0]]\n"), "t")
    log = simulate(sc, _Drive())
    c = log.collision
    assert log.outcome == "collided" and c["obstacle"] == "wall" and c["index"] == 0
    # the disc (0.35 m) touches x = 3 when its centre reaches 2.65 m, at 0.4 m/s from rest reached at once
    assert c["time_s"] == pytest.approx(2.65 / 0.4, abs=0.5 / 20 + 1e-9)
    assert c["robot_speed_towards_mps"] == pytest.approx(0.4)
    doc = run_document(log)
    assert doc["walls"] == [{"points": [[3.0, -2.0], [3.0, 2.0]]}] and doc["collision"]["obstacle"] == "wall"


def test_a_wall_beside_the_path_is_passed_and_measured():
    sc = scenario_from_dict(tomllib.loads(BASE + "[[walls]]\npoints = [[-1.0, 0.6], [8.0, 0.6]]\n"), "t")
    log = simulate(sc, _Drive())
    assert log.outcome == "reached_goal"
    assert log.min_clearance_m == pytest.approx(0.6 - 0.35, abs=1e-9)


def test_walkers_do_not_walk_through_walls():
    """A walker whose goal lies behind a wall does not cross it (navground's line obstacles);
    without the wall it walks straight there."""
    walker = ('[[moving_obstacles]]\nposition = [3.0, -3.0]\nradius_m = 0.3\nbehaviour = "orca"\n'
              'goal = [3.0, 3.0]\npreferred_speed_mps = 0.5\n')
    wall = "[[walls]]\npoints = [[1.0, 0.0], [5.0, 0.0]]\n"
    for with_wall in (False, True):
        sc = scenario_from_dict(tomllib.loads(BASE.replace("line_m = 6.0", "line_m = 0.5") + walker
                                              + (wall if with_wall else "")), "t")
        ep = Episode(sc, 0.5)
        ep.world.advance(16.0)
        path = ep.world.positions(np.arange(0.0, 16.0, 0.1))[:, 0]
        if with_wall:   # never closer to the wall than its own disc
            assert min(sc.walls[0].distance_m(path)) >= 0.3 - 1e-6
        else:
            assert np.allclose(path[-1], (3.0, 3.0), atol=0.06)


def test_plots_draw_the_walls(tmp_path):
    f = tmp_path / "w.toml"
    f.write_text(BASE + "[[walls]]\npoints = [[-1.0, 1.0], [8.0, 1.0]]\n[[walls]]\npoints = [[-1.0, -1.0], [8.0, -1.0]]\n")
    png = tmp_path / "w.png"
    assert main(["simulate", str(f), "--controller", "blind", "--plot", str(png), "--out", str(tmp_path / "r.json")]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    import json
    assert len(json.loads((tmp_path / "r.json").read_text())["walls"]) == 2



def test_the_view_takes_the_walls_beside_what_happens_not_their_lengths_beyond_it():
    """A room's wall 0.65 m below the robot's path was left out of the figure (walls did not
    set the view): now a wall beside the view widens it, up to 1.5 m, and a wall that runs on
    along it does not stretch it."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scenarios.plots import plot_run, walls_beside
    corridor = [np.array([[-50.0, 1.25], [50.0, 1.25]]), np.array([[-50.0, -1.25], [50.0, -1.25]])]
    near = walls_beside(corridor, (0.0, 10.0), (-0.5, 0.5))
    assert near[:, 0].min() >= 0.0 and near[:, 0].max() <= 10.0 and set(np.round(near[:, 1], 9)) == {1.25, -1.25}
    assert len(walls_beside(corridor, (0.0, 10.0), (3.0, 4.0))) == 0      # 1.75 m and more away
    room = np.array([[-4.0, -4.0], [4.0, -4.0], [4.0, 4.0], [-4.0, 4.0], [-4.0, -4.0]])
    doc = {"trajectory": {"t": [0.0, 1.0], "x": [-3.0, 2.0], "y": [-3.0, -3.0], "heading_rad": [0.0, 0.0]},
           "sample_time_s": 0.5, "walls": [{"points": room.tolist()}], "obstacles": [], "scenario": "room",
           "controller": "gpc", "outcome": "timed_out", "min_clearance_m": 0.1}
    fig, ax = plt.subplots()
    plot_run(ax, doc)
    fig.canvas.draw()
    (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
    assert y0 <= -4.0 and x0 <= -4.0      # the floor's wall and the side's, 0.65 m and 0.65 m away
    assert y1 < 4.0                        # the far wall, 6.65 m away, is not brought in
    plt.close(fig)

def test_the_check_layer_measures_the_distance_to_a_walls_segments_exactly():
    """The check's distance to a wall is the distance to its segments (the simulator's rule):
    from a point, as the scenario's own geometry measures it; from a chord (the robot's
    motion between two sub-samples), the least distance over points taken densely along it,
    to within the sampling's error, and zero where the chord crosses the wall."""
    from casadi_gpc.safety.walls import path_segment_distances, point_segment_distance, wall_segments
    pts = ((0.0, 0.0), (3.0, 0.0), (3.0, 2.05))
    seg = wall_segments((pts,))
    rng = np.random.default_rng(0)
    q = rng.uniform((-1, -2), (5, 4), size=(2000, 2))
    d = point_segment_distance(q[:, 0] + 1j * q[:, 1], seg[:, 0, None], seg[:, 1, None]).min(axis=0)
    np.testing.assert_allclose(d, Wall(pts).distance_m(q), rtol=0, atol=1e-12)
    paths = rng.uniform((-1, -2), (5, 4), size=(300, 2, 2))
    p = paths[..., 0] + 1j * paths[..., 1]                                   # (300, 2): one chord each
    got = np.array([path_segment_distances(np.ascontiguousarray(c), np.array(seg)).min() for c in p])
    s = np.linspace(0.0, 1.0, 4001)
    dense = p[:, :1] + s * (p[:, 1:] - p[:, :1])                            # (300, 4001)
    xy = np.stack([dense.real.ravel(), dense.imag.ravel()], axis=1)
    brute = Wall(pts).distance_m(xy).reshape(dense.shape).min(axis=1)
    step = np.abs(p[:, 1] - p[:, 0]) / 4000
    assert np.all(got <= brute + 1e-12) and np.all(got >= brute - step)
    assert (got == 0.0).sum() > 10  # chords across the wall


def test_behind_the_check_layer_a_controller_does_not_drive_into_a_wall():
    """Every controller behind the check layer is checked against the walls: one that drives
    blind at a wall is stopped short of it; beside a wall it is left alone."""
    from casadi_gpc.safety import Shield
    ahead = scenario_from_dict(tomllib.loads(BASE + "[[walls]]\npoints = [[3.0, -2.0], [3.0, 2.0]]\n"), "t")
    sh = Shield(_Drive())
    log = simulate(ahead, sh)
    assert log.outcome != "collided" and log.min_clearance_m > 0.0
    assert sh.counters["interventions"] > 0
    beside = scenario_from_dict(tomllib.loads(BASE + "[[walls]]\npoints = [[-1.0, 0.7], [8.0, 0.7]]\n"), "t")
    sh = Shield(_Drive())
    assert simulate(beside, sh).outcome == "reached_goal" and sh.counters["interventions"] == 0


def test_walls_hide_what_is_behind_them():
    """The sensor does not see through walls: a mover behind a wall is not measured until the
    line from the robot to it is clear."""
    from scenarios.simulator import _blocked
    seg = np.array([[[1.0, -1.0], [1.0, 1.0]]])
    seen = ~_blocked(np.array([0.0, 0.0]), np.array([[2.0, 0.0], [0.5, 3.0], [2.0, 3.0], [0.5, 0.0]]), seg)
    assert seen.tolist() == [False, True, True, True]

    class _Still:
        sample_time_s = 0.5
        seen: list = []

        def reset(self):
            pass

        def decide(self, obs):
            self.seen.append(tuple(m.obstacle_id for m in obs.moving))
            return ControlDecision(0.0, 0.0)
    # a person walks up behind a wall (x = 2, y from -1 to 1) and comes out at its end
    body = (BASE.replace("line_m = 6.0", "line_m = 0.5") + "[[walls]]\npoints = [[2.0, -1.0], [2.0, 1.0]]\n"
            + "[[moving_obstacles]]\nradius_m = 0.3\ntrack = [[0.0, 4.0, -0.5], [6.0, 4.0, 2.5]]\n")
    pol = _Still()
    simulate(scenario_from_dict(tomllib.loads(body), "t"), pol)
    first = next(k for k, ids in enumerate(pol.seen) if ids)
    # the line from (0, 0) to (4, y) leaves the wall's end (2, 1) behind once y > 2
    assert 0 < first and (-0.5 + 0.5 * first * 0.5) > 2.0 - 0.25


@pytest.mark.parametrize("kind", ["corridor", "doorway", "corner"])
def test_the_building_suites_are_seeded_buildings_with_people_in_them(kind):
    from scenarios import Suite
    from scenarios.building_suite import CORRIDOR_WIDTH_M, DOOR_WIDTH_M
    a, b = Suite(kind, 3, 1, 6).scenario(2), Suite(kind, 9, 1, 6).scenario(2)
    assert a.name == b.name and a.moving == b.moving and a.walls == b.walls and len(a.moving) == 6
    assert Suite(kind, 3, 2, 6).scenario(2).moving != a.moving
    assert all(m.behaviour == "orca" and not m.sees_robot for m in a.moving)
    pts = np.concatenate([np.asarray(w.points) for w in a.walls])
    if kind == "corridor":
        assert np.ptp(pts[:, 1]) == pytest.approx(CORRIDOR_WIDTH_M)
    if kind == "doorway":
        ends = sorted(abs(p[1]) for w in a.walls for p in w.points)
        assert 2 * ends[0] == pytest.approx(DOOR_WIDTH_M)
    for m in a.moving:   # every leg of every person's path keeps its disc off the walls
        legs = np.linspace(m.xy_m[:-1], m.xy_m[1:], 50).reshape(-1, 2)
        assert min(w.distance_m(legs).min() for w in a.walls) >= m.radius_m
    ep = Episode(a, 0.5)
    ep.world.advance(20.0)
    xy = ep.world.positions(np.arange(0.0, 20.0, 0.1)).reshape(-1, 2)
    xy = xy[np.isfinite(xy[:, 0])]
    assert min(w.distance_m(xy).min() for w in a.walls) >= 0.3 - 0.02   # the walkers keep off the walls


def test_the_navground_peers_are_given_the_walls():
    """A peer (navground's ORCA) driven at a wall across its path stops short of it: navground
    takes the walls as line obstacles."""
    from casadi_gpc.config import preset
    from gpcnav.controllers import ControllerSpec, make
    sc = scenario_from_dict(tomllib.loads(BASE + "[[walls]]\npoints = [[3.0, -3.0], [3.0, 3.0]]\n"), "t")
    log = simulate(sc, make(ControllerSpec("orca"), preset("improved"), sc.robot))
    assert log.outcome != "collided" and log.min_clearance_m > 0.0


@pytest.mark.parametrize("kind", ["corridor", "doorway", "corner"])
def test_a_scenario_written_back_reads_the_same(kind, tmp_path):
    """scenarios.writer: the loader reads back what it writes (a building suite's scenario:
    walls, track walkers, a reference with an arc)."""
    from scenarios import Suite, load_scenario
    from scenarios.writer import scenario_document, to_toml
    sc = Suite(kind, 2, 3, 4).scenario(1)
    f = tmp_path / "back.toml"
    f.write_text(to_toml(scenario_document(sc)))
    back = load_scenario(f)
    assert back.moving == sc.moving and back.walls == sc.walls and back.sensing == sc.sensing
    assert back.name == sc.name and back.duration_s == sc.duration_s and back.robot == sc.robot
    assert back.reference.length_m == pytest.approx(sc.reference.length_m)
    assert np.allclose(back.reference.end_pose, sc.reference.end_pose, atol=1e-9)


def test_the_animation_shows_the_walls_the_figure_shows(tmp_path, monkeypatch):
    """The animation took walls within 1 m of what moves (the figure: 1.5 m) and not the
    reference: a robot alone in a 2.5 m corridor was animated between y = -1 and 1, neither wall
    in view; a run cut short by a collision lost the rest of its reference."""
    import json

    from scenarios import plots
    f = tmp_path / "c.toml"
    f.write_text(BASE + "[[walls]]\npoints = [[-20.0, 1.25], [20.0, 1.25]]\n[[walls]]\n"
                        "points = [[-20.0, -1.25], [20.0, -1.25]]\n")
    assert main(["simulate", str(f), "--controller", "blind", "--out", str(tmp_path / "r.json")]) == 0
    doc = json.loads((tmp_path / "r.json").read_text())
    made = []
    subplots = plots.plt.subplots
    monkeypatch.setattr(plots.plt, "subplots", lambda *a, **k: made.append(subplots(*a, **k)) or made[-1])
    for run in (doc, {**doc, "trajectory": {k: v[:3] for k, v in doc["trajectory"].items()}}):
        plots.animate_run(run, tmp_path / "c.gif")
        assert (tmp_path / "c.gif").read_bytes()[:3] == b"GIF"
        ax = made[-1][1]
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        assert y0 < -1.25 and y1 > 1.25 and x1 < 20.0, (y0, y1)     # both sides, not their lengths
        assert x1 >= doc["reference_path"][-1][0]                   # the whole reference
