"""The Team API without the simulator: hand-made observations in, velocity commands out."""

from __future__ import annotations

import re

import numpy as np
import pytest

from helpers import shipped
from resilient_tracking.observation import Attack, TeamObservation, ZoneClue
from resilient_tracking.team import Team


def observation(step, positions, targets, sensing_ok, links, attacks=()):
    m = len(positions)
    delta = targets[None, :, :] - positions[:, None, :]
    z = np.stack(
        [np.hypot(delta[..., 0], delta[..., 1]), np.arctan2(delta[..., 1], delta[..., 0])], axis=-1
    )
    z[~sensing_ok] = np.nan
    return TeamObservation(
        step=step,
        time=0.1 * step,
        positions=positions,
        measurements=z,
        sensing_ok=sensing_ok,
        comm_ok=np.ones(m, bool),
        sensing_persistence=tuple("" if ok else "permanent" for ok in sensing_ok),
        comm_persistence=("",) * m,
        links=links,
        attacks=tuple(attacks),
    )


def test_team_turns_observations_into_bounded_commands_toward_the_targets():
    s = shipped("sensing-perm")
    targets = np.array([[1.0, 1.0], [1.5, 0.5], [1.0, 0.0]])
    team = Team.from_scenario(s, np.column_stack([targets, np.zeros((3, 2))]))
    positions = np.array([[-2.0, 1.0], [-2.0, 0.0], [-2.0, -1.0]])
    links = ~np.eye(3, dtype=bool)
    for k in range(20):
        out = team.step(observation(k, positions, targets, np.ones(3, bool), links))
        assert out.controls.shape == (3, 2)
        assert np.all(np.abs(out.controls) <= 1.0 + 1e-9)
        positions = positions + 0.1 * out.controls
    assert np.all(positions[:, 0] > -1.6)  # moved toward the targets
    assert team.belief.team_estimate().position_trace() < 0.5


def test_an_attack_clue_becomes_league_knowledge_and_a_constraint():
    s = shipped("sensing-perm")
    targets = np.zeros((3, 2))  # all three on the zone's mean
    team = Team.from_scenario(s, np.zeros((3, 4)))
    positions = np.array([[-0.8, 0.3], [-1.5, 0.0], [-1.5, -0.6]])
    links = ~np.eye(3, dtype=bool)
    clue = ZoneClue(
        zone_id=0,
        kind="sensing",
        mu=np.array([0.0, 0.0]),
        sigma=0.3 * np.eye(2),
        size=0.5,
        persistence="permanent",
    )
    sensing = np.array([False, True, True])
    out = team.step(observation(0, positions, targets, sensing, links, [Attack(0, clue)]))
    assert all("zone0" in team.belief.knowledge[i] for i in range(3))
    assert {out.decision.modes[i] for i in range(3)} == {"league"}
    # the working robots do not close in on a target that sits on the zone's mean
    for k in range(1, 30):
        out = team.step(observation(k, positions, targets, sensing, links))
        positions = positions + 0.1 * out.controls
    assert np.linalg.norm(positions[1:], axis=1).min() > 0.8


def test_lists_are_accepted_and_every_event_of_the_tick_is_returned():
    s = shipped("sensing-perm")
    team = Team.from_scenario(s, [[1.0, 1.0], [1.5, 0.5], [1.0, 0.0]])  # positions only
    clue = ZoneClue(0, "sensing", np.zeros(2), 0.3 * np.eye(2), 0.5, "permanent")
    obs = TeamObservation(
        step=0,
        time=0.0,
        positions=[[-0.8, 0.3], [-1.5, 0.0], [-1.5, -0.6]],
        measurements=np.full((3, 3, 2), np.nan).tolist(),
        sensing_ok=[False, True, True],
        comm_ok=[True, True, True],
        sensing_persistence=["permanent", "", ""],
        comm_persistence=["", "", ""],
        links=[[False, True, True], [True, False, True], [True, True, False]],
        attacks=[Attack(0, clue)],
    )
    out = team.step(obs)
    kinds = [e.event for e in out.events]
    assert kinds[0] == "attack" and out.events[0].robot == 0
    learned = [e for e in out.events if e.event == "zone_learned"]
    assert {e.robot for e in learned} == {0, 1, 2}  # the victim's clue, then the broadcast


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"positions": np.zeros((3, 3))}, "TeamObservation.positions"),
        ({"measurements": np.zeros((3, 2, 2))}, "TeamObservation.measurements"),
        ({"measurements": np.zeros((2, 3, 2))}, "TeamObservation.measurements"),
        ({"sensing_ok": [True, True]}, "TeamObservation.sensing_ok"),
        ({"comm_persistence": ("", "")}, "TeamObservation.comm_persistence"),
        ({"sensing_persistence": ("", "forever", "")}, "TeamObservation.sensing_persistence"),
        ({"links": np.eye(3, dtype=bool)[:2]}, "TeamObservation.links"),
        ({"links": np.triu(np.ones((3, 3), bool))}, "TeamObservation.links"),
        ({"recoveries": [(5, "sensing")]}, "TeamObservation.recoveries"),
    ],
)
def test_bad_observations_name_the_field(change, field):
    s = shipped("sensing-perm")
    team = Team.from_scenario(s, np.zeros((3, 4)))
    base = observation(
        0, np.zeros((3, 2)), np.ones((3, 2)), np.ones(3, bool), ~np.eye(3, dtype=bool)
    )
    fields = {**base.__dict__, **change}
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        team.step(TeamObservation(**fields))


def test_initial_means_of_the_wrong_size_are_named():
    s = shipped("sensing-perm")  # three targets
    with pytest.raises(ValueError, match="initial_means: the scenario has 3 targets, got 4"):
        Team.from_scenario(s, np.zeros((4, 4)))
    with pytest.raises(ValueError, match=r"initial_means: expected shape"):
        Team.from_scenario(s, np.zeros((3, 3)))


def test_an_observation_with_other_targets_than_the_team_is_named():
    s = shipped("sensing-perm")
    team = Team.from_scenario(s, np.zeros((3, 4)))
    obs = observation(
        0, np.zeros((3, 2)), np.ones((2, 2)), np.ones(3, bool), ~np.eye(3, dtype=bool)
    )
    with pytest.raises(ValueError, match="TeamObservation.measurements: the team tracks 3"):
        team.step(obs)


def test_leagues_follow_the_links_even_when_they_change_in_place():
    team = Team.from_scenario(shipped("sensing-temp"), np.zeros((3, 2)))
    positions = np.array([[-1.0, 0.0], [0.0, 0.0], [1.0, 0.0]])
    targets = np.zeros((3, 2)) + 0.5
    links = np.ones((3, 3), bool)
    np.fill_diagonal(links, False)
    seen = []
    for step, cut in enumerate([False, False, True, True, False]):
        links[2, :2] = links[:2, 2] = not cut  # the same array, edited between ticks
        team.step(observation(step, positions, targets, np.ones(3, bool), links))
        seen.append([list(league) for league in team.belief.leagues])
    whole, split = [[0, 1, 2]], [[0, 1], [2]]
    assert seen == [whole, whole, split, split, whole]


@pytest.mark.parametrize(
    ("robots", "targets", "channels", "message"),
    [
        (2, 3, 2, "TeamObservation.positions: the team has 3 robots, got 2"),
        (3, 2, 2, "TeamObservation.measurements: the team tracks 3 targets, got 2"),
        (3, 3, 1, "the team's sensor measures 2 channel(s), got 1"),
    ],
)
def test_an_observation_that_does_not_fit_the_team_is_refused_naming_the_field(
    robots, targets, channels, message
):
    team = Team.from_scenario(shipped("sensing-perm"), np.zeros((3, 4)))
    obs = TeamObservation(
        step=0,
        time=0.0,
        positions=np.zeros((robots, 2)),
        measurements=np.ones((robots, targets, channels)),
        sensing_ok=np.ones(robots, bool),
        comm_ok=np.ones(robots, bool),
        sensing_persistence=("",) * robots,
        comm_persistence=("",) * robots,
        links=~np.eye(robots, dtype=bool),
    )
    with pytest.raises(ValueError, match=re.escape(message)):
        team.perceive(obs)
