"""What the learning environments refuse, and that a refusal changes nothing: unknown or
missing agents, actions of the wrong shape or kind, steps with no episode running, and
constructor or ``reset`` arguments of the wrong kind. After each refusal the episode goes on
exactly as an episode that never saw it (docs/reliability.md §14)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("pettingzoo")

import gymnasium  # noqa: E402
import yaml  # noqa: E402

from resilient_tracking import builtin_scenarios  # noqa: E402
from resilient_tracking.env import TeamEnv, parallel_env  # noqa: E402

SCENARIO = "sensing-temp"  # three robots
STEPS = 3
SEED = 4
AGENTS = "robot_0, robot_1, robot_2"
KINDS = ("team", "parallel")


def ID(value):
    """A test id: an exception class by its name, any other value as written."""
    return value.__name__ if isinstance(value, type) else repr(value)


def make(kind, **options):
    """An environment of ``SCENARIO``: the team (Gymnasium) or the agents (PettingZoo)."""
    options.setdefault("steps", STEPS)
    scenario = options.pop("scenario", SCENARIO)
    if kind == "team":
        return TeamEnv(scenario, **options)
    return parallel_env(scenario, **options)


def valid_action(env):
    """Half of every robot's speed bound, for the whole team or every live agent."""
    if isinstance(env, TeamEnv):
        return 0.5 * env.action_space.high
    return {agent: 0.5 * env.action_space(agent).high for agent in env.agents}


def started(kind):
    """An environment one valid step into an episode at ``SEED``."""
    env = make(kind)
    env.reset(seed=SEED)
    env.step(valid_action(env))
    return env


def refused(error, words, call):
    """``call()`` raises ``error`` with a one-line message holding every one of ``words``."""
    with pytest.raises(error) as caught:
        call()
    message = str(caught.value)
    assert "\n" not in message
    for word in words:
        assert word in message, (word, message)
    return caught.value


def same(a, b):
    """Equal, down to every array of nested dicts and tuples."""
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, tuple):
        return len(a) == len(b) and all(map(same, a, b))
    return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)


def tables(env):
    """The run tables so far (all but wall-clock ``timing``)."""
    result = env.session.result()
    return {name: result[name].copy() for name in sorted(set(result.tables) - {"timing"})}


def assert_same_tables(first, second):
    assert first.keys() == second.keys()
    for name in first:
        pd.testing.assert_frame_equal(first[name], second[name], check_exact=True, obj=name)


def assert_goes_on_as(env, twin):
    """The rest of ``env``'s episode (valid steps to the end) is ``twin``'s, step by step and
    table by table."""
    assert env.session.stepper.seed == twin.session.stepper.seed
    steps = 0
    while not twin.session.ended:
        assert same(env.step(valid_action(env)), twin.step(valid_action(twin)))
        steps += 1
    assert steps > 0 and env.session.ended
    assert_same_tables(tables(env), tables(twin))


# ---------------------------------------------------------------- the agents of a parallel step

Z = np.zeros(2)


@pytest.mark.parametrize(
    ("actions", "words"),
    [
        ({"robot0": Z, "robot1": Z, "robot2": Z}, ["'robot0', 'robot1', 'robot2'", AGENTS]),
        ({"robot_0": Z, "robot_1": Z, "robot_2": Z, "robot_3": Z}, ["'robot_3'", AGENTS]),
        ({0: Z, 1: Z, 2: Z}, ["agent(s) 0, 1, 2", AGENTS]),
        ({"robot_0": Z, "robot_2": Z}, ["no action for robot_1", AGENTS]),
        ({}, ["no action for robot_0, robot_1, robot_2"]),
    ],
    ids=["misspelled", "one-too-many", "numbered", "one-left-out", "none"],
)
def test_actions_not_naming_exactly_the_live_agents_are_refused_before_stepping(actions, words):
    env, twin = started("parallel"), started("parallel")
    refused(ValueError, ["actions: ", *words], lambda: env.step(actions))
    assert_goes_on_as(env, twin)


@pytest.mark.parametrize(
    ("action", "error", "words"),
    [
        (np.zeros(3), ValueError, ["shape (3,)"]),
        (np.zeros((1, 2)), ValueError, ["shape (1, 2)"]),
        (0.5, ValueError, ["shape ()"]),
        (None, TypeError, ["got NoneType"]),
        ("ab", TypeError, ["got str"]),
        (np.array([True, False]), TypeError, ["got ndarray of bool"]),
        ([0.1, [0.2]], TypeError, ["got a ragged list"]),
    ],
    ids=["three", "a-row", "scalar", "none", "text", "bools", "ragged"],
)
def test_an_agents_action_of_the_wrong_shape_or_kind_is_refused_naming_the_agent(
    action, error, words
):
    env, twin = started("parallel"), started("parallel")
    actions = valid_action(env) | {"robot_1": action}
    expected = ["action of robot_1: ", "shape (2,)", "Box(", *words]
    refused(error, expected, lambda: env.step(actions))
    assert_goes_on_as(env, twin)


def test_actions_that_are_not_a_dictionary_are_refused():
    env, twin = started("parallel"), started("parallel")
    listed = list(valid_action(env).values())
    refused(TypeError, ["actions: expected a dict", "got list"], lambda: env.step(listed))
    assert_goes_on_as(env, twin)


# ---------------------------------------------------------------- the team's action


@pytest.mark.parametrize(
    ("action", "error", "words"),
    [
        (np.full(2, 0.2), ValueError, ["got shape (2,) (nothing is broadcast)"]),
        (np.full((2, 2), 0.2), ValueError, ["got shape (2, 2)"]),
        (np.full((3, 2, 1), 0.2), ValueError, ["got shape (3, 2, 1)"]),
        (np.full(6, 0.2), ValueError, ["got shape (6,)"]),
        (0.2, ValueError, ["got shape ()"]),
        (None, TypeError, ["got NoneType"]),
        ({"robot_0": Z}, TypeError, ["got dict"]),
        (np.ones((3, 2), dtype=bool), TypeError, ["got ndarray of bool"]),
        (np.ones((3, 2), dtype=complex), TypeError, ["got ndarray of complex128"]),
        ([[0.1, 0.2], [0.1], [0.1, 0.2]], TypeError, ["got a ragged list"]),
    ],
    ids=["one-row", "two-rows", "extra-axis", "flat", "scalar", "none", "dict"]
    + ["bools", "complex", "ragged"],
)
def test_a_team_action_of_the_wrong_shape_or_kind_is_refused_before_stepping(action, error, words):
    env, twin = started("team"), started("team")
    expected = ["action: ", "shape (3, 2)", "Box(", *words]
    refused(error, expected, lambda: env.step(action))
    assert_goes_on_as(env, twin)


def test_one_robots_velocity_is_not_given_to_every_robot_of_a_two_robot_team(tmp_path):
    document = yaml.safe_load(builtin_scenarios.path(SCENARIO).read_text())
    document["robots"] = document["robots"][:2]
    two = tmp_path / "two-robots.yaml"
    two.write_text(yaml.safe_dump(document))
    env = TeamEnv(str(two), steps=STEPS)
    env.reset(seed=SEED)
    before = env.session.running.world.robot_positions.copy()
    words = ["action: ", "shape (2, 2)", "got shape (2,) (nothing is broadcast)"]
    refused(ValueError, words, lambda: env.step(np.array([0.2, 0.1])))
    assert np.array_equal(env.session.running.world.robot_positions, before)
    assert env.session.running.steps_done == 0


def test_a_team_action_of_integers_lists_or_float32_is_the_same_velocity():
    env, twin = started("team"), started("team")
    as_float32 = np.full((3, 2), 0.25, dtype=np.float32)
    assert same(env.step(as_float32), twin.step(as_float32.astype(np.float64)))
    assert same(env.step(np.zeros((3, 2), dtype=int)), twin.step([[0.0, 0.0]] * 3))


# ---------------------------------------------------------------- steps with no episode running


@pytest.mark.parametrize("kind", KINDS)
def test_a_step_before_the_first_reset_is_refused(kind):
    env = make(kind)
    caught = refused(gymnasium.error.ResetNeeded, ["call reset()"], lambda: env.step(None))
    assert isinstance(caught, RuntimeError)


@pytest.mark.parametrize("kind", KINDS)
def test_a_step_past_the_end_of_the_episode_is_refused_and_records_nothing(kind):
    env = started(kind)
    ended = False
    while not ended:
        *_, terminated, truncated, _ = env.step(valid_action(env))
        ended = all(truncated.values()) if kind == "parallel" else truncated
    before = tables(env)
    assert len(before["team"]) == STEPS  # steps 0, 1 and 2, recorded once each
    words = ["episode has ended", f"step {STEPS}", "call reset()"]
    refused(gymnasium.error.ResetNeeded, words, lambda: env.step(valid_action(env)))
    refused(gymnasium.error.ResetNeeded, words, lambda: env.step(0.5 * np.ones((3, 2))))
    assert_same_tables(tables(env), before)
    env.reset()  # the next episode steps again
    env.step(valid_action(env))
    assert env.session.running.steps_done == 1


def test_a_step_after_every_sensor_failed_is_refused():
    from resilient_tracking.world.world import Failure

    env = started("team")
    env.session.running.world.failures["sensing"] = [Failure("permanent", 0, 0)] * 3
    _, _, terminated, truncated, _ = env.step(valid_action(env))
    assert terminated and not truncated
    refused(gymnasium.error.ResetNeeded, ["episode has ended"], lambda: env.step(Z))


# ---------------------------------------------------------------- reset and constructor arguments

BAD_SEEDS = [
    (-1, ValueError),
    (1.7, TypeError),
    (2.0, TypeError),
    (True, TypeError),
    ("3", TypeError),
    (np.float64(3), TypeError),
]


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize(("seed", "error"), BAD_SEEDS, ids=ID)
def test_a_bad_reset_seed_is_refused_and_the_old_episode_goes_on(kind, seed, error):
    env, twin = started(kind), started(kind)
    words = ["seed: expected an integer of at least 0", f"got {seed!r}"]
    refused(error, words, lambda: env.reset(seed=seed))
    assert_goes_on_as(env, twin)
    first, again = env.reset(), twin.reset()  # the same next seed: SEED + 1
    assert same(first, again) and env.session.stepper.seed == SEED + 1


@pytest.mark.parametrize("kind", KINDS)
def test_a_numpy_integer_seed_is_that_seed(kind):
    env, twin = make(kind), make(kind)
    assert same(env.reset(seed=np.int64(7)), twin.reset(seed=7))
    assert env.session.stepper.seed == 7 and type(env.session.stepper.seed) is int


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize(
    ("argument", "value", "error"),
    [
        ("seed", -1, ValueError),
        ("seed", 1.7, TypeError),
        ("seed", True, TypeError),
        ("max_zones", -1, ValueError),
        ("max_zones", 2.5, TypeError),
        ("max_zones", False, TypeError),
        ("steps", 0, ValueError),
        ("steps", 2.5, TypeError),
        ("steps", True, TypeError),
        ("expert", 3, TypeError),
        ("team", 3, TypeError),
        ("reward", 3.0, TypeError),
        ("record", "no", TypeError),
        ("scenario", 3, TypeError),
    ],
    ids=ID,
)
def test_a_bad_constructor_argument_is_refused_naming_it(kind, argument, value, error):
    refused(error, [f"{argument}: "], lambda: make(kind, **{argument: value}))
