"""Zone knowledge that ages and moves (docs/model.md §6.3): the per-zone filter, its sharing,
the knowledge planned against, and the failure-aware team with ``zone_motion``."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from helpers import shipped
from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
from resilient_tracking.belief.settings import BeliefSettings
from resilient_tracking.belief.zone_motion import ZoneMotionSettings, ZoneMotionTracker, ZoneTrack
from resilient_tracking.observation import Attack, TeamObservation, ZoneClue
from resilient_tracking.planning.layout import SensingRow
from resilient_tracking.scenario.overrides import overridden
from resilient_tracking.team import Team

VELOCITY = np.array([0.3, -0.2])
START = np.array([1.0, 2.0])
SIGMA = 0.3 * np.eye(2)
DT = 0.1


def settings(**changes: Any) -> ZoneMotionSettings:
    values: dict[str, Any] = dict(
        enabled=True, accel_std=0.02, speed_std=0.5, mean_std=0.05, max_std=0.0, refresh=0.0
    )
    values.update(changes)
    return ZoneMotionSettings(**values)


def mean_at(step: int) -> np.ndarray:
    """The moving zone's prior mean at ``step`` (0.1 s steps)."""
    return START + VELOCITY * 0.1 * step


def estimate(step: int, zone_id: int | None = 0, key: str = "zone0") -> ZoneEstimate:
    return ZoneEstimate(
        key=key,
        kind="sensing",
        mean=mean_at(step),
        cov=SIGMA,
        size=0.5,
        persistence="permanent",
        source="attack",
        learned_step=step,
        zone_id=zone_id,
    )


# ---------------------------------------------------------------------------- the filter


def test_successive_clues_estimate_the_zone_velocity():
    s = settings()
    track = ZoneTrack.start(mean_at(0), 0, s)
    np.testing.assert_array_equal(track.velocity, [0.0, 0.0])  # one clue: no motion known
    for step in (15, 30, 50, 80):
        track = track.update(mean_at(step), step, s, DT)
    assert track.clues == 5 and track.step == 80
    np.testing.assert_allclose(track.velocity, VELOCITY, atol=0.01)
    state, _ = track.predict(130, s, DT)
    np.testing.assert_allclose(state[:2], mean_at(130), atol=0.05)


def test_a_still_zone_is_estimated_still():
    s = settings()
    track = ZoneTrack.start(START, 0, s)
    for step in (20, 40, 60):
        track = track.update(START, step, s, DT)
    np.testing.assert_allclose(track.velocity, [0.0, 0.0], atol=1e-3)


def test_knowledge_grows_uncertain_with_time_since_the_last_clue():
    s = settings(speed_std=0.05)
    track = ZoneTrack.start(START, 10, s)
    spreads = [np.trace(track.predict(step, s, DT)[1][:2, :2]) for step in (10, 20, 60, 200)]
    assert all(b > a for a, b in zip(spreads, spreads[1:], strict=False))
    # a second clue shrinks it again
    updated = track.update(START, 200, s, DT)
    assert np.trace(updated.predict(200, s, DT)[1][:2, :2]) < spreads[-1] / 10


def test_predicted_knowledge_widens_up_to_the_cap():
    kb = KnowledgeBase({"zone0": estimate(0)})
    for cap, bounded in ((0.4, True), (0.0, False)):
        tracker = ZoneMotionTracker(1, settings(speed_std=0.1, max_std=cap), DT)
        tracker.observe(0, estimate(0), 0)
        near = tracker.predicted([0], kb, 5).zones["zone0"]
        far = tracker.predicted([0], kb, 500).zones["zone0"]
        assert np.trace(near.cov) > np.trace(SIGMA)
        assert np.trace(far.cov) > np.trace(near.cov)
        added = np.linalg.eigvalsh(far.cov - SIGMA)[-1]
        assert (added <= 0.4**2 + 1e-12) == bounded


def test_the_prediction_is_republished_only_after_moving_more_than_refresh():
    tracker = ZoneMotionTracker(1, settings(refresh=0.1, accel_std=0.0), DT)
    tracker.observe(0, estimate(0), 0)
    tracker.observe(0, estimate(20), 20)  # velocity (0.3, -0.2): 0.036 m per step
    kb = KnowledgeBase({"zone0": estimate(0)})
    first = tracker.predicted([0], kb, 21).zones["zone0"]
    assert tracker.predicted([0], kb, 22).zones["zone0"] is first  # moved 0.036 m
    later = tracker.predicted([0], kb, 25).zones["zone0"]  # moved 0.144 m
    assert later is not first
    np.testing.assert_allclose(later.mean, mean_at(25), atol=0.02)


def test_unidentified_estimates_stay_where_they_were_learned():
    tracker = ZoneMotionTracker(1, settings(), DT)
    circle = estimate(0, zone_id=None, key="circle1@0")
    tracker.observe(0, circle, 0)
    kb = KnowledgeBase({circle.key: circle})
    assert tracker.predicted([0], kb, 100).zones[circle.key] is circle


def test_a_league_shares_the_newest_track_and_other_leagues_keep_theirs():
    tracker = ZoneMotionTracker(3, settings(), DT)
    tracker.observe(0, estimate(0), 0)
    tracker.observe(1, estimate(0), 0)
    tracker.observe(1, estimate(30), 30)  # robot 1 saw the zone again
    tracker.observe(2, estimate(0), 0)
    tracker.share([[0, 1], [2]])
    assert tracker.tracks[0]["zone0"] is tracker.tracks[1]["zone0"]
    assert tracker.tracks[0]["zone0"].clues == 2
    assert tracker.tracks[2]["zone0"].clues == 1


# ---------------------------------------------------------------------------- the team


def observation(step: int, positions: np.ndarray, targets: np.ndarray, attacks=()):
    sensing_ok = np.array([i >= len(attacks_so_far(step)) for i in range(3)])
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
        comm_ok=np.ones(3, bool),
        sensing_persistence=tuple("" if ok else "permanent" for ok in sensing_ok),
        comm_persistence=("",) * 3,
        links=~np.eye(3, dtype=bool),
        attacks=tuple(attacks),
    )


#: steps at which robots 0 and 1 are attacked by the moving zone
ATTACK_STEPS = (0, 20)


def attacks_so_far(step: int) -> list[int]:
    return [k for k in ATTACK_STEPS if k <= step]


def clue(step: int) -> ZoneClue:
    return ZoneClue(0, "sensing", mean_at(step), SIGMA, 0.5, "permanent")


def run_team(zone_motion: dict[str, Any] | None, steps: int = 30):
    """The sensing-perm team fed hand-made observations: the zone attacks robot 0 at step 0 and
    robot 1 at step 20, each clue where the zone then was. Returns the team and the sensing
    rows of each league plan."""
    s = shipped("sensing-perm")
    if zone_motion is not None:
        s = overridden(s, {f"belief.zone_motion.{k}": v for k, v in zone_motion.items()})
    team = Team.from_scenario(s, np.zeros((3, 4)))
    rows: list[tuple[int, np.ndarray]] = []
    solve = team.policy.solve  # type: ignore[attr-defined]

    def spy(robots, q, step, decision):
        rows.append((step, q.sensing_zones.copy()))
        return solve(robots, q, step, decision)

    team.policy.solve = spy  # type: ignore[attr-defined]
    positions = np.array([[-2.0, 1.0], [-2.0, 0.0], [-2.0, -1.0]])
    targets = np.array([[-1.0, 1.0], [-1.0, 0.0], [-1.0, -1.0]])
    for step in range(steps):
        victims = [i for i, k in enumerate(ATTACK_STEPS) if k == step]
        attacks = [Attack(i, clue(step)) for i in victims]
        out = team.step(observation(step, positions, targets, attacks))
        positions = positions + 0.1 * out.controls
    return team, rows


def test_option_off_plans_against_the_zone_as_learned():
    assert not BeliefSettings().zone_motion.enabled
    team, rows = run_team(None)
    assert team.belief.zone_motion is None
    step, table = rows[-1]
    np.testing.assert_array_equal(table[0, SensingRow.MEAN], mean_at(0))  # the first clue
    assert team.belief.plan_knowledge([0, 1, 2], step + 1) is team.belief.league_knowledge(
        [0, 1, 2]
    )


def test_league_rows_use_the_zone_predicted_at_plan_time():
    team, rows = run_team({"enabled": True, "speed_std": 0.5, "refresh": 0.0})
    tracker = team.belief.zone_motion
    assert tracker is not None
    track = tracker.tracks[2]["zone0"]
    assert track.clues == 2  # the victims' clues reached the third robot
    step, table = rows[-1]
    state, cov = track.predict(step + 1, tracker.settings, tracker.dt)
    row = table[0]
    np.testing.assert_allclose(row[SensingRow.MEAN], state[:2])
    grown = SIGMA + cov[:2, :2]
    np.testing.assert_allclose(row[SensingRow.COVARIANCE], grown[[0, 0, 1], [0, 1, 1]])
    # the prediction follows the zone: nearer where it is at plan time than the first clue
    assert np.linalg.norm(state[:2] - mean_at(step + 1)) < 0.3 * np.linalg.norm(
        mean_at(0) - mean_at(step + 1)
    )


def test_belief_is_built_from_clues_alone():
    team, _ = run_team({"enabled": True, "speed_std": 0.5})
    tracker = team.belief.zone_motion
    assert tracker is not None
    replay = ZoneTrack.start(mean_at(0), 0, tracker.settings).update(
        mean_at(20), 20, tracker.settings, tracker.dt
    )
    held = tracker.tracks[0]["zone0"]
    np.testing.assert_array_equal(held.state, replay.state)
    np.testing.assert_array_equal(held.cov, replay.cov)


@pytest.mark.parametrize("field", ["accel_std", "speed_std", "max_std", "refresh"])
def test_zone_motion_numbers_are_bounded(field):
    with pytest.raises(ValueError, match=field):
        BeliefSettings.model_validate({"zone_motion": {field: -1.0}})
