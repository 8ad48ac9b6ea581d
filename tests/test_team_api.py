"""The Team API without the simulator: hand-made observations in, velocity commands out."""

from __future__ import annotations

import numpy as np

from conftest import shipped
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
    targets = np.array([[0.0, 0.0]])
    team = Team.from_scenario(s, np.array([[0.0, 0.0, 0.0, 0.0]]))
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
