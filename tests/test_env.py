"""The learning environments: PettingZoo and Gymnasium checkers, seeds, fidelity to
``rtrack run``, rendering and the reward."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("gymnasium")
pytest.importorskip("pettingzoo")

import gymnasium  # noqa: E402
from gymnasium.utils.env_checker import check_env  # noqa: E402
from pettingzoo.test import parallel_api_test, parallel_seed_test  # noqa: E402

from helpers import shipped  # noqa: E402
from resilient_tracking.cli import main  # noqa: E402
from resilient_tracking.env import TEAM_ENV_ID, TeamEnv, TrackingReward, parallel_env  # noqa: E402
from resilient_tracking.experiments.catalog import SIX  # noqa: E402
from resilient_tracking.scenario.overrides import overridden  # noqa: E402
from resilient_tracking.sim.episode import run_episode  # noqa: E402

STEPS = 25


@pytest.fixture(scope="module")
def generated(tmp_path_factory):
    """A scenario file written by ``rtrack generate``."""
    out = tmp_path_factory.mktemp("generated")
    assert main(["generate", "-n", "1", "--seed", "5", "--out", str(out), "--quiet"]) == 0
    (path,) = sorted(out.glob("*.yaml"))
    return str(path)


@pytest.mark.parametrize("name", [*SIX, "generated"])
def test_parallel_env_passes_the_pettingzoo_api_and_seed_tests(name, generated):
    scenario = generated if name == "generated" else name
    parallel_api_test(parallel_env(scenario, seed=3, steps=STEPS), num_cycles=STEPS + 5)
    parallel_seed_test(lambda: parallel_env(scenario, steps=STEPS))


def test_team_env_passes_the_gymnasium_checker_and_is_registered():
    check_env(TeamEnv("comm-temp", steps=STEPS), skip_render_check=False)
    env = gymnasium.make(TEAM_ENV_ID, scenario="sensing-perm", steps=STEPS)
    obs, info = env.reset(seed=2)
    assert env.observation_space.contains(obs)
    assert obs["targets"].shape == (3, 3, 4) and info["step"] == 0


def random_episode(env, seed):
    """Observations and rewards of an episode of random actions (drawn from ``seed``)."""
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    seen, rewards = [obs], []
    while env.agents:
        actions = {a: rng.uniform(-1, 1, 2) * env.action_space(a).high for a in env.agents}
        obs, reward, *_ = env.step(actions)
        seen.append(obs)
        rewards.append(reward)
    return seen, rewards


def test_the_same_seed_gives_the_same_episode_and_another_seed_another():
    first = random_episode(parallel_env("combined-temp", steps=STEPS), seed=7)
    again = random_episode(parallel_env("combined-temp", steps=STEPS), seed=7)
    other = random_episode(parallel_env("combined-temp", steps=STEPS), seed=8)

    def flat(run):
        return np.concatenate([v.ravel() for o in run[0] for a in o.values() for v in a.values()])

    assert np.array_equal(flat(first), flat(again))
    assert first[1] == again[1]
    assert not np.array_equal(flat(first), flat(other))


def expert_driven(name, seed, steps=None):
    """The tables of an environment episode whose every action is the expert's."""
    env = parallel_env(name, steps=steps)
    env.reset(seed=seed)
    while env.agents:
        env.step(env.expert_actions())
    return env.session.result()


@pytest.mark.parametrize(
    ("name", "seed", "steps"), [("sensing-temp", 1, None), ("comm-perm", 2, 120)]
)
def test_driven_by_the_failure_aware_policy_the_environment_equals_rtrack_run(name, seed, steps):
    scenario = shipped(name) if steps is None else shipped(name).with_overrides(steps=steps)
    run = run_episode(scenario, policy="failure_aware", seed=seed)
    env = expert_driven(name, seed, steps)
    assert set(env.tables) == set(run.tables)
    for table in sorted(set(run.tables) - {"timing"}):  # timing holds wall-clock solve times
        pd.testing.assert_frame_equal(env[table], run[table], check_exact=True, obj=table)
    assert (run["team"]["n_solves"] > 0).any()  # the planner's decisions, not the agents'
    assert (run["robots"]["mode"] != "agent").all()


def test_actions_of_agents_are_recorded_clipped_and_never_invalid():
    env = parallel_env("sensing-temp", steps=10)
    env.reset(seed=0)
    while env.agents:
        env.step({a: np.array([1e3, -1e3]) for a in env.agents})
    tables = env.session.result()
    robots = tables["robots"]
    assert (robots["mode"] == "agent").all()
    u_max = shipped("sensing-temp").robots[0].u_max
    assert np.allclose(robots["ux"].abs().max(), u_max)
    assert (tables["events"]["event"] != "invalid_decision").all()


def test_an_action_that_is_not_finite_holds_its_robot_as_an_invalid_decision():
    env = parallel_env("sensing-temp", steps=3)
    env.reset(seed=0)
    before = env.session.running.world.robot_positions.copy()
    actions = {a: np.array([0.2, 0.1]) for a in env.agents}
    actions[env.agents[1]] = np.array([np.nan, 0.0])
    env.step(actions)
    after = env.session.running.world.robot_positions
    assert np.array_equal(after[1], before[1])  # robot 1 held its position
    assert not np.array_equal(after[0], before[0])
    events = env.session.result()["events"]
    invalid = events[events["event"] == "invalid_decision"]
    assert invalid["robot"].tolist() == [1]


def test_a_view_without_room_for_zones_leaves_out_the_zones_known():
    known = overridden(shipped("sensing-perm"), {"zones.0.known": True})
    obs, _ = TeamEnv(known, max_zones=0, steps=3).reset(seed=0)
    assert obs["zones"].shape == (3, 0, 7) and obs["zones_mask"].shape == (3, 0)
    obs, _ = TeamEnv(known, steps=3).reset(seed=0)
    assert obs["zones_mask"][:, 0].tolist() == [1.0, 1.0, 1.0]  # every robot knows it


def test_observations_are_what_the_robot_knows():
    env = parallel_env("sensing-perm", steps=STEPS)
    obs, _ = env.reset(seed=1)
    view = obs["robot_1"]
    belief = env.session.running.team.belief
    assert np.allclose(view["targets"], belief.estimates[belief.league_of[1]].mean)
    assert view["teammates_mask"].tolist() == [1.0, 0.0, 1.0]  # one league, itself excluded
    assert view["own"][3] == 1.0 and view["zones_mask"].sum() == 0  # sensing, knows no zone


def test_the_reward_is_the_trace_decrease_less_the_attack_penalty():
    env = parallel_env("sensing-temp", steps=5, reward=TrackingReward(1.0, 10.0))
    obs, info = env.reset(seed=0)
    trace = info["robot_0"]["trace"]
    _, rewards, *_, infos = env.step(env.expert_actions())
    after = infos["robot_0"]
    expected = trace - after["trace"] - 10.0 * after["attacks"]
    assert rewards["robot_0"] == pytest.approx(expected)


def test_every_robot_blind_terminates_the_episode():
    env = parallel_env("sensing-perm", steps=300, reward=lambda outcome: float(outcome.sensing))
    env.reset(seed=0)
    from resilient_tracking.world.world import Failure

    env.session.running.world.failures["sensing"] = [Failure("permanent", 0, 0)] * 3
    _, rewards, terminations, truncations, _ = env.step(env.expert_actions())
    assert all(terminations.values()) and not any(truncations.values())
    assert set(rewards.values()) == {0.0} and env.agents == []


def lose_for_good(env, robot):
    """Take robot ``robot``'s sensor and radio for good, as a permanent zone would."""
    from resilient_tracking.world.world import Failure

    failures = env.session.running.world.failures
    failures["sensing"][robot] = failures["comm"][robot] = Failure("permanent", 0, 0)


def test_with_retire_an_agent_that_can_neither_sense_nor_talk_leaves_and_its_robot_holds():
    env = parallel_env("combined-perm", steps=STEPS, retire=True, record=False)
    env.reset(seed=0)
    lose_for_good(env, 0)
    _, rewards, terminations, truncations, infos = env.step(env.expert_actions())
    assert terminations == {"robot_0": True, "robot_1": False, "robot_2": False}
    assert not any(truncations.values()) and set(rewards) == set(infos) == set(terminations)
    assert env.agents == ["robot_1", "robot_2"]
    held = env.session.running.obs.positions[0].copy()
    with pytest.raises(ValueError, match="unknown agent.*robot0"):
        env.step({"robot0": np.ones(2), **{a: np.ones(2) for a in env.agents}})
    observations, rewards, *_ = env.step({a: np.ones(2) for a in env.agents})
    assert set(observations) == set(rewards) == {"robot_1", "robot_2"}
    # an action for the retired agent (TorchRL sends one for every agent) is ignored
    env.step({a: np.ones(2) for a in env.possible_agents})
    assert np.array_equal(env.session.running.obs.positions[0], held)


def test_without_retire_every_agent_stays_to_the_end():
    env = parallel_env("combined-perm", steps=STEPS, record=False)
    env.reset(seed=0)
    lose_for_good(env, 0)
    _, _, terminations, *_ = env.step(env.expert_actions())
    assert not any(terminations.values()) and env.agents == env.possible_agents


def test_with_retire_the_environment_passes_the_pettingzoo_api_test():
    parallel_api_test(parallel_env("combined-perm", seed=3, steps=STEPS, retire=True), STEPS + 5)
    with pytest.raises(TypeError, match="retire"):
        parallel_env("combined-perm", retire="yes")


def test_render_draws_the_map_of_the_run_so_far():
    env = TeamEnv("sensing-perm", steps=STEPS, render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(5):
        env.step(env.expert_action())
    frame = env.render()
    assert frame is not None and frame.shape == (480, 640, 3) and frame.dtype == np.uint8
    assert len(np.unique(frame.reshape(-1, 3), axis=0)) > 10  # something drawn
    assert TeamEnv("sensing-perm", steps=STEPS).render() is None


def test_after_a_split_each_robot_sees_its_own_leagues_estimate():
    env = TeamEnv("comm-perm", steps=300)
    obs, info = env.reset(seed=1)
    while info["n_leagues"] < 2:
        obs, _, terminated, truncated, info = env.step(env.expert_action())
        assert not (terminated or truncated), "no split happened"
    belief = env.session.running.team.belief
    for robot in range(3):
        league = belief.league_of[robot]
        estimate = belief.estimates[league]
        assert np.array_equal(obs["targets"][robot], estimate.mean.astype(np.float32))
        assert np.array_equal(obs["target_cov"][robot], estimate.cov.astype(np.float32))
        mates = [i for i in belief.leagues[league] if i != robot]
        assert np.flatnonzero(obs["teammates_mask"][robot]).tolist() == mates
    assert not np.array_equal(obs["targets"][0], obs["targets"][1]) or not np.array_equal(
        obs["targets"][1], obs["targets"][2]
    )


def test_without_recording_the_episode_is_the_same_and_has_no_tables():
    recorded = random_episode(parallel_env("combined-temp", steps=STEPS), seed=5)
    env = parallel_env("combined-temp", steps=STEPS, record=False)
    unrecorded = random_episode(env, seed=5)
    for seen, again in zip(recorded[0], unrecorded[0], strict=True):
        for agent, view in seen.items():
            for field, value in view.items():
                assert np.array_equal(value, again[agent][field]), (agent, field)
    assert recorded[1] == unrecorded[1]
    with pytest.raises(RuntimeError, match="record=False"):
        env.session.result()
    with pytest.raises(ValueError, match="record=False"):
        TeamEnv("sensing-temp", render_mode="rgb_array", record=False)


def test_without_recording_the_info_holds_the_recorded_mse():
    infos = []
    for record in (True, False):
        env = TeamEnv("sensing-temp", steps=STEPS, record=record)
        env.reset(seed=2)
        env.action_space.seed(2)
        infos.append([env.step(env.action_space.sample())[-1] for _ in range(STEPS)])
    mses = [[info["mse"] for info in run] for run in infos]
    assert mses[0] == mses[1] and np.isfinite(mses[0]).all()
    assert infos[0] == infos[1]
