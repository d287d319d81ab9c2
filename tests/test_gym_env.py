"""``gpcnav/Navigation-v0``: Gymnasium's own checker, seeded resets, terminated apart from
truncated, the observation's known values, an episode driven by the GPC to the goal, and
the default scene (the registration by id: test_gym_entry_point.py)."""
from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from conftest import PAPER_DIR  # noqa: E402
from gpcnav.gym_env import DEFAULT_SUITE, NavigationEnv, ObservationLayout, RewardSettings  # noqa: E402

LINE = """
name = "line"
duration_s = {duration}
[robot]
position = [1.0, 2.0]
heading_deg = 90.0
[reference]
position = [1.0, 2.0]
heading_deg = 90.0
speed_mps = 0.4
[[reference.segments]]
line_m = 4.0
{extra}
"""


def _file(tmp_path, duration=20.0, extra=""):
    path = tmp_path / "line.toml"
    path.write_text(LINE.format(duration=duration, extra=extra), encoding="utf-8")
    return path


@pytest.mark.parametrize("kwargs", [{"suite": "circle-crossing", "movers": 3}, {"suite": "random-multi"},
                                    {"scenario": PAPER_DIR / "fig7_2_crossing.toml"}])
def test_gymnasium_s_checker_passes_without_a_warning(kwargs):
    from gymnasium.utils.env_checker import check_env
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(NavigationEnv(**kwargs), skip_render_check=True)


def test_reset_with_a_seed_is_reproducible():
    env = NavigationEnv(suite="circle-crossing", movers=4)
    runs = []
    for seed in (7, 7, 8):
        obs, info = env.reset(seed=seed)
        trace = [obs]
        for _ in range(5):
            trace.append(env.step(np.array([0.3, 0.35], dtype=np.float32))[0])
        runs.append((info["scenario"], np.stack(trace)))
    assert runs[0][0] == runs[1][0] and np.array_equal(runs[0][1], runs[1][1])
    assert runs[2][0] != runs[0][0]
    # count: a fixed set of episodes; options: one of them by index
    env = NavigationEnv(suite="circle-crossing", count=2, suite_seed=3)
    names = {env.reset(seed=s)[1]["scenario"] for s in range(12)}
    assert names == {"circle-crossing-orca-5-3-0000", "circle-crossing-orca-5-3-0001"}
    assert env.reset(options={"index": 5})[1]["scenario"] == "circle-crossing-orca-5-3-0005"


def test_the_observation_has_its_known_values(tmp_path):
    static = "[[static_obstacles]]\nposition = [0.0, 4.0]\nradius_m = 0.25\n"
    env = NavigationEnv(scenario=_file(tmp_path, extra=static))
    obs, info = env.reset(seed=0)
    v = dict(zip(env.layout.names(), obs.tolist()))
    assert len(obs) == ObservationLayout().size == env.observation_space.shape[0] == 58
    # the robot at (1, 2) facing +y: the reference point ahead is along x (forward)
    assert (v["ref0_dx"], v["ref0_dy"]) == pytest.approx((0.0, 0.0), abs=1e-6)
    assert (v["ref2_dx"], v["ref2_dy"]) == pytest.approx((0.4, 0.0), abs=1e-6)   # 2 steps of 0.5 s at 0.4 m/s
    assert (v["goal_dx"], v["goal_dy"], v["time_left_s"]) == pytest.approx((4.0, 0.0, 10.0), abs=1e-5)
    # the disc at (0, 4): 2 m ahead, 1 m to the right
    assert (v["static0_dx"], v["static0_dy"], v["static0_radius"], v["static0_present"]) == \
        pytest.approx((2.0, 1.0, 0.25, 1.0), abs=1e-6)
    assert v["static1_present"] == 0.0 and v["mover0_present"] == 0.0
    assert info["clearance_m"] == pytest.approx(math.hypot(1.0, 2.0) - 0.25 - 0.35, abs=1e-6)


def test_terminated_is_the_goal_or_a_collision_truncated_the_time_limit(tmp_path):
    env = NavigationEnv(scenario=_file(tmp_path, duration=12.0))
    env.reset(seed=0)
    while True:
        _, reward, terminated, truncated, info = env.step([0.4, 0.4])
        if terminated or truncated:
            break
    assert (terminated, truncated, info["outcome"]) == (True, False, "reached_goal")
    assert info["t_s"] == pytest.approx(10.0) and reward == pytest.approx(1.0 + 0.1 * 0.2, abs=1e-6)  # the goal and 0.2 m of progress
    env.reset(seed=0)
    steps = 0
    while True:
        _, _, terminated, truncated, info = env.step([0.0, 0.0])
        steps += 1
        if terminated or truncated:
            break
    assert (terminated, truncated, info["outcome"], steps) == (False, True, "timed_out", 24)
    wall = "[[static_obstacles]]\nposition = [1.0, 3.5]\nradius_m = 0.3\n"
    env = NavigationEnv(scenario=_file(tmp_path, extra=wall))
    env.reset(seed=0)
    while True:
        _, reward, terminated, truncated, info = env.step([0.4, 0.4])
        if terminated or truncated:
            break
    assert (terminated, truncated, info["outcome"]) == (True, False, "collided") and reward < 0
    with pytest.raises(RuntimeError):
        env.step([0.0, 0.0])


def test_actions_not_applied_as_given_are_counted_in_info(tmp_path):
    """An action beyond the wheel limit was clipped, and a NaN one braked for, said nowhere in what the
    agent is told (the simulator's events only): now counted in ``info`` per episode."""
    env = NavigationEnv(scenario=_file(tmp_path))
    _, info = env.reset(seed=0)
    assert (info["clipped_actions"], info["non_finite_actions"]) == (0, 0)
    _, _, _, _, info = env.step([2.0, 0.4])
    assert (info["clipped_actions"], info["non_finite_actions"]) == (1, 0)
    clipped = env.unwrapped.observation.robot.as_array()
    _, _, _, _, info = env.step([float("nan"), 0.4])
    _, _, _, _, info = env.step([0.8, -0.8])  # at the limit: applied as given
    assert (info["clipped_actions"], info["non_finite_actions"]) == (1, 1)
    env.reset(seed=0)
    env.step([0.8, 0.4])  # the clipped action is the one at the limit
    np.testing.assert_array_equal(env.unwrapped.observation.robot.as_array(), clipped)
    _, info = env.reset(seed=0)
    assert (info["clipped_actions"], info["non_finite_actions"]) == (0, 0)


def test_an_observation_outside_the_space_is_clipped_into_it_and_counted(tmp_path):
    """A static disc of 15 m radius (the space's radii end at 10 m): the observation was handed out
    outside the declared space (Gymnasium's checker warned); now clipped into it and counted per
    episode. A scene within the bounds counts none."""
    from gymnasium.utils.env_checker import check_env
    big = "[[static_obstacles]]\nposition = [10.0, 20.0]\nradius_m = 15.0\n"
    env = NavigationEnv(scenario=_file(tmp_path, extra=big))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=0)
    assert env.observation_space.contains(obs) and info["clipped_observations"] == 1
    radius = env.unwrapped.layout.names().index("static0_radius")
    assert obs[radius] == np.float32(10.0)
    obs, *_, info = env.step([0.3, 0.3])
    assert env.observation_space.contains(obs) and info["clipped_observations"] == 2
    (tmp_path / "plain").mkdir()
    plain = NavigationEnv(scenario=_file(tmp_path / "plain"))
    _, info = plain.reset(seed=0)
    assert info["clipped_observations"] == 0 and plain.step([0.3, 0.3])[4]["clipped_observations"] == 0


def test_an_action_at_the_action_space_s_float32_bound_is_not_counted_as_clipped(tmp_path):
    """The Box's high is float32(0.8) = 0.800000012: an action the space contains, counted as clipped
    (a GPC expert's float32 expert_action at the wheel limit was too, 7 of an episode's 30)."""
    env = NavigationEnv(scenario=_file(tmp_path))
    env.reset(seed=0)
    high, low = env.action_space.high, env.action_space.low
    assert env.action_space.contains(high) and float(high[0]) > 0.8
    _, _, _, _, info = env.step(high)
    _, _, _, _, info = env.step(low)
    assert info["clipped_actions"] == 0
    _, _, _, _, info = env.step(np.nextafter(high, np.float32(1.0)))  # the next float32 up: beyond the space
    assert info["clipped_actions"] == 1


def test_an_episode_driven_by_the_gpc_reaches_the_goal():
    env = NavigationEnv(scenario=PAPER_DIR / "fig7_1_head_on.toml", expert="gpc")
    obs, info = env.reset(seed=1)
    while True:
        obs, _, terminated, truncated, info = env.step(info["expert_action"])
        if terminated or truncated:
            break
    assert info["outcome"] == "reached_goal" and info["min_clearance_m"] > 0.2


def test_any_controller_of_the_protocol_drives_it_through_the_observation():
    """A peer that decides every 0.1 s drives an environment made with that step."""
    from casadi_gpc.config import preset
    from gpcnav.controllers import ControllerSpec, make
    env = NavigationEnv(scenario=PAPER_DIR / "fig7_2_crossing.toml", sample_time_s=0.1)
    _, info = env.reset(seed=2)
    orca = make(ControllerSpec("orca"), preset("improved"), env.episode.scenario.robot)
    assert orca.sample_time_s == env.sample_time_s
    orca.reset()
    while True:
        d = orca.decide(env.observation)
        _, _, terminated, truncated, info = env.step([d.v_right_mps, d.v_left_mps])
        if terminated or truncated:
            break
    assert info["outcome"] == "reached_goal" and 40.0 <= info["t_s"] < 45.0  # 16 m at 0.4 m/s, a detour


def test_with_no_keyword_argument_the_default_scene_is_the_crowd_suite():
    """Tools that make environments by id alone get :data:`DEFAULT_SUITE` with its defaults."""
    env = NavigationEnv()
    assert (env.suite.name, env.suite.movers, env.suite.behaviour) == (DEFAULT_SUITE, 5, "orca") == \
        ("circle-crossing", 5, "orca")
    _, info = env.reset(seed=4)
    assert info["scenario"].startswith("circle-crossing-orca-5-0-") and len(env.episode.scenario.moving) == 5
    with pytest.raises(ValueError):
        NavigationEnv(scenario=PAPER_DIR / "fig7_2_crossing.toml", suite="random")


def test_walls_give_the_expert_wall_slots_and_count_in_the_clearance(tmp_path):
    """A scenario with walls: the expert plans with the preset's wall slots (as the command
    line's runs do), one without keeps the NLP it had; ``clearance_m`` is the gap to the
    nearest wall when a wall is nearest (the robot at (1, 2), a wall 0.5 m to its right)."""
    from casadi_gpc.config import WALL_SLOTS
    pytest.importorskip("torch")
    walled = _file(tmp_path, extra="[[walls]]\npoints = [[1.5, 0.0], [1.5, 9.0]]\n")
    env = NavigationEnv(scenario=walled, expert="mppi")
    _, info = env.reset(seed=0)
    assert env.expert.config.max_walls == WALL_SLOTS
    assert info["clearance_m"] == pytest.approx(0.5 - 0.35)
    while True:  # driven by its expert, the robot keeps off the wall
        _, _, terminated, truncated, info = env.step(info["expert_action"])
        assert info["clearance_m"] > 0
        if terminated or truncated:
            break
    assert info["outcome"] == "reached_goal" and env.expert.counters["walls_unpriced"] == 0
    (tmp_path / "plain").mkdir()
    plain = NavigationEnv(scenario=_file(tmp_path / "plain"), expert="mppi")
    _, info = plain.reset(seed=0)
    assert plain.expert.config.max_walls == 0 and info["clearance_m"] == math.inf


def test_with_nothing_to_keep_clear_of_both_clearances_are_infinite(tmp_path):
    """One convention in info: ``clearance_m`` and ``min_clearance_m`` are ``inf`` (a Python float)
    from the reset to the episode's end when there is nothing to keep clear of; only the JSON
    documents, which cannot hold infinity, write 1e9 m for it (docs/gym.md, docs/scenarios.md)."""
    from scenarios.metrics import episode_metrics
    env = NavigationEnv(scenario=_file(tmp_path, duration=2.0))
    _, info = env.reset(seed=0)
    assert info["clearance_m"] == info["min_clearance_m"] == math.inf
    terminated = truncated = False
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step([0.4, 0.4])
        assert info["clearance_m"] == info["min_clearance_m"] == math.inf
    assert info["outcome"] == "timed_out" and episode_metrics(env.episode.log).min_clearance_m == 1e9


def test_a_deep_copy_after_reset_steps_on_as_the_original_and_apart_from_it():
    """copy.deepcopy of the environment after reset() failed: its ORCA walkers hold navground's
    objects ("cannot pickle 'navground.core._navground.GeometricState' object"). Now a copy
    steps on as the original does, and stepping one copy leaves the others as they were."""
    import copy
    env = NavigationEnv()  # the default scene: ORCA walkers
    env.reset(seed=0)
    for _ in range(3):
        env.step([0.2, 0.2])
    other, twin = copy.deepcopy(env), copy.deepcopy(env)
    assert twin.episode.world.has_walkers and twin.episode.world is not env.episode.world
    for _ in range(3):
        other.step([-0.3, 0.3])
    steps = 0
    for k in range(40):
        a = [0.1 + 0.02 * (k % 4), 0.15]
        got, want = twin.step(a), env.step(a)
        assert np.array_equal(got[0], want[0]) and got[1:] == want[1:]
        steps += 1
        if want[2] or want[3]:
            break
    assert steps >= 10 and twin.episode.world.counters["walker_steps"] > 0


def test_an_expert_that_cannot_be_copied_makes_the_copy_a_clear_type_error():
    import copy
    env = NavigationEnv(expert="nn")
    env.reset(seed=0)
    with pytest.raises(TypeError, match=r"^NavigationEnv: expert 'nn' cannot be copied \(cannot pickle "
                                        r"'.*InferenceSession' object\): make another environment"):
        copy.deepcopy(env)


def test_a_scenario_shorter_than_one_step_has_one_step_cut_at_its_duration(tmp_path):
    """Its reset() said the episode had timed out and the first step() then asked for a reset (any
    training loop stopped there), so such a file was refused when the environment was made; the
    simulator now runs it as one interval cut at duration_s, as the last of a longer run."""
    short = NavigationEnv(scenario=_file(tmp_path, duration=0.1))
    _, info = short.reset(seed=0)
    assert info["outcome"] == "running"
    *_, terminated, truncated, info = short.step(np.zeros(2, dtype=np.float32))
    assert truncated and not terminated and info["outcome"] == "timed_out"
    assert short.unwrapped.episode.log.t[-1] == pytest.approx(0.1)  # driven up to duration_s
    assert info["t_s"] == pytest.approx(0.1)  # (it said 0.5 s, the next sample's time, past the end)
    env = NavigationEnv(scenario=_file(tmp_path, duration=0.5))  # one step: it can be taken
    env.reset(seed=0)
    *_, terminated, truncated, info = env.step(np.zeros(2, dtype=np.float32))
    assert truncated and not terminated and info["outcome"] == "timed_out"


@pytest.mark.parametrize("kwargs, words", [
    ({"sample_time_s": 0}, "sample_time_s must be at least 0.05 s"),  # was taken as "the preset's"
    ({"sample_time_s": float("nan")}, "sample_time_s must be at least 0.05 s"),
    ({"sample_time_s": 1e-9}, "sample_time_s must be at least 0.05 s"),  # was taken: 2e10 steps in 20 s
    ({"expert": "nope"}, "expert 'nope': not a controller"),  # was refused only at the first reset
    ({"suite": "random", "movers": 7}, "movers: suite random has its own movers"),  # taken and ignored
    ({"suite": "encounters", "behaviour": "orca"}, "behaviour: suite encounters has its own movers"),
    ({"scenario": PAPER_DIR / "fig7_2_crossing.toml", "movers": 7, "behaviour": "orca"}, "options of a suite"),
    ({"scenario": PAPER_DIR / "fig7_2_crossing.toml", "suite_seed": 3}, "options of a suite"),
    ({"render_mode": "human"}, "renders nothing"),  # was a TypeError
])
def test_keywords_it_cannot_honour_are_refused_when_made(kwargs, words):
    with pytest.raises(ValueError, match=words):
        NavigationEnv(**kwargs)


def test_render_without_a_render_mode_returns_none():
    """Gymnasium's convention for render_mode None; the base class raised NotImplementedError
    through every wrapper of gymnasium.make."""
    import gymnasium
    env = gymnasium.make("gpcnav:gpcnav/Navigation-v0", suite="circle-crossing", movers=2)
    env.reset(seed=0)
    assert env.render() is None and env.unwrapped.render() is None


def test_a_negative_episode_index_is_refused():
    env = NavigationEnv(suite="circle-crossing", movers=3, count=2)
    env.reset(seed=0, options={"index": 1})
    with pytest.raises(ValueError, match="an episode of the suite is 0 or more"):
        env.reset(seed=0, options={"index": -1})


@pytest.mark.parametrize("index", [2.7, 1.0, True, "1", "a"])
def test_an_episode_index_that_is_no_whole_number_is_refused(index):
    """options index 2.7 ran episode 2 and True episode 1 (int() of them), as count=2.5 was taken
    before it was refused; "a" was int()'s own message, naming no option."""
    env = NavigationEnv(suite="circle-crossing", movers=3, count=2)
    with pytest.raises(ValueError, match=r"^options index .*: an episode of the suite is a whole number, 0 or more$"):
        env.reset(seed=0, options={"index": index})
    assert env.reset(seed=0, options={"index": np.int64(1)})[1]["scenario"] == "circle-crossing-orca-3-0-0001"


@pytest.mark.parametrize("count", [2.5, True, "3"])
def test_a_count_that_is_no_whole_number_is_refused_when_made(count):
    """count=2.5 was taken (each reset drew from [0, 2.5)); it is a number of episodes."""
    with pytest.raises(ValueError, match="count must be a whole number of episodes"):
        NavigationEnv(suite="circle-crossing", movers=3, count=count)
    assert NavigationEnv(suite="circle-crossing", movers=3, count=np.int64(2)).count == 2


@pytest.mark.parametrize("key, value", [("movers", True), ("movers", 2.5), ("suite_seed", True), ("suite_seed", 1.5),
                                        ("suite_seed", "a")])
def test_movers_and_a_suite_seed_that_are_no_whole_number_are_refused_when_made(key, value):
    """movers=True ran one mover and suite_seed=True suite 1 (bools are ints); suite_seed "a" and 1.5
    were TypeErrors naming no keyword ("'<' not supported ...", "seed must be integer")."""
    with pytest.raises(ValueError, match=rf"^{key} must be a whole number, 0 or more, got "):
        NavigationEnv(suite="circle-crossing", **{"movers": 3, key: value})
    assert NavigationEnv(suite="circle-crossing", movers=np.int64(2), suite_seed=np.int64(1)).suite.movers == 2


@pytest.mark.parametrize("kw", [{"scenario": PAPER_DIR / "fig7_2_crossing.toml"}, {"suite": "circle-crossing"}])
def test_an_option_reset_does_not_read_is_refused(kw):
    """A misspelt option ("idx") was taken and ignored: a random episode ran in its place."""
    env = NavigationEnv(**kw)
    with pytest.raises(ValueError, match=r"^options 'idx': not an option of reset \(it reads only index\)$"):
        env.reset(seed=0, options={"idx": 3})
    env.reset(seed=0, options={})


def test_an_episode_index_given_to_a_file_is_refused():
    """options index picks a suite's episode; a file's one episode ran whatever index was given."""
    env = NavigationEnv(scenario=PAPER_DIR / "fig7_2_crossing.toml")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="options index: episodes of a suite"):
        env.reset(seed=0, options={"index": 3})
    env.reset(seed=0, options={})


def test_an_expert_network_that_cannot_drive_the_file_s_robot_is_refused_when_made(tmp_path):
    """expert="nn" on a file whose robot is larger than the network's 0.35 m: a ValueError
    naming the file when the environment is made (it was a UsageError at the first reset);
    a smaller robot it drives."""
    text = (PAPER_DIR / "fig7_2_crossing.toml").read_text()
    big, small = tmp_path / "big.toml", tmp_path / "small.toml"
    big.write_text(text.replace("[robot]\n", "[robot]\nradius_m = 0.4\n", 1))
    small.write_text(text.replace("[robot]\n", "[robot]\nradius_m = 0.25\n", 1))
    with pytest.raises(ValueError, match=r"expert 'nn' on .*big\.toml: .*another robot"):
        NavigationEnv(scenario=big, expert="nn")
    env = NavigationEnv(scenario=small, expert="nn")
    assert "expert_action" in env.reset(seed=0)[1]


@pytest.mark.parametrize("expert", ["gpc", "stand"])
def test_an_expert_of_another_sample_time_is_refused_when_made(expert):
    """An expert deciding every 0.5 s in an environment stepping every 0.25 s, and navground's
    ORCA (every 0.1 s) in one stepping every 0.5 s: a ValueError when the environment is made
    (it was raised at the first reset); an expert at the environment's own step is made."""
    with pytest.raises(ValueError, match=rf"expert '{expert}' decides every 0.5 s, the environment steps every 0.25 s"):
        NavigationEnv(suite="circle-crossing", expert=expert, sample_time_s=0.25)
    NavigationEnv(suite="circle-crossing", expert=expert)
    with pytest.raises(ValueError, match=r"expert 'orca' decides every 0.1 s, the environment steps every 0.5 s"):
        NavigationEnv(suite="circle-crossing", expert="orca")
    NavigationEnv(suite="circle-crossing", expert="orca", sample_time_s=0.1)


@pytest.mark.parametrize("kw, words", [
    ({"layout": {"movers": 3}}, "layout must be a gpcnav.gym_env.ObservationLayout"),
    ({"reward": None}, "reward must be a gpcnav.gym_env.RewardSettings"),
])
def test_a_layout_or_reward_of_another_type_is_refused_when_made(kw, words):
    """None or a dict failed at the first reset or step (AttributeError naming neither)."""
    with pytest.raises(ValueError, match=words):
        NavigationEnv(suite="circle-crossing", movers=2, **kw)


@pytest.mark.parametrize("make, words", [
    (lambda: ObservationLayout(movers=-1), "ObservationLayout.movers must be a whole number of at least 0"),
    (lambda: ObservationLayout(reference_points=0), "reference_points must be a whole number of at least 1"),
    (lambda: ObservationLayout(statics=1.5), "statics must be a whole number of at least 0"),
    (lambda: RewardSettings(goal=float("nan")), "RewardSettings.goal must be a finite number"),
    (lambda: RewardSettings(progress_per_m="0.1"), "progress_per_m must be a finite number"),
])
def test_a_layout_or_reward_no_environment_can_use_is_refused(make, words):
    """movers=-1 made a vector of 52 values (one slot taken off), reference_points=0 an
    IndexError at the first reset, and a NaN reward NaN rewards."""
    with pytest.raises(ValueError, match=words):
        make()
    env = NavigationEnv(suite="circle-crossing", movers=2, layout=ObservationLayout(movers=0, statics=0),
                        reward=RewardSettings(progress_per_m=0))
    assert env.reset(seed=0)[0].shape == (16,) == env.observation_space.shape
