"""Suspect targets of the failure-aware policy's lure guard: which targets become suspect, and
robots keeping their stand-off from them."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.planning.layout import sensing_row, sensing_table
from resilient_tracking.policies.guards.lure import LureGuardParams
from resilient_tracking.policies.guards.suspects import SuspectWatch
from resilient_tracking.scenario import parse_scenario
from resilient_tracking.sim.episode import run_episode

DT = 0.1


def estimate(positions: np.ndarray, std: float = 0.05) -> TargetEstimate:
    """Estimates at ``positions`` ``(N, 2)`` with velocity zero and position spread ``std``."""
    n = len(positions)
    mean = np.zeros((n, 4))
    mean[:, :2] = positions
    cov = np.tile(np.diag([std**2, std**2, 0.04, 0.04]), (n, 1, 1))
    return TargetEstimate(mean, cov)


def watch_path(path: np.ndarray, zone_rows: np.ndarray | None = None, std: float = 0.05):
    """Feed a watch the path ``(T, N, 2)`` of estimated target positions; its events."""
    watch = SuspectWatch(2, LureGuardParams(), DT)
    rows = sensing_table() if zone_rows is None else zone_rows
    events = []
    for step, positions in enumerate(path):
        events += watch.observe(step, [0, 1], estimate(positions, std), rows)
    return watch, events


def test_a_target_that_stops_after_moving_becomes_suspect_and_a_moving_one_does_not():
    steps = np.arange(80)
    lure = np.stack([np.minimum(steps, 40) * 0.03, np.zeros(80)], axis=1)  # 0.3 m/s, then still
    mover = np.stack([steps * 0.02, np.ones(80)], axis=1)  # 0.2 m/s throughout
    watch, events = watch_path(np.stack([lure, mover], axis=1))
    assert watch.suspect[:, 0].all() and not watch.suspect[:, 1].any()
    assert {e.cause for e in events} == {"linger"}
    assert {e.robot for e in events} == {0, 1}
    first = min(e.step for e in events)
    params = LureGuardParams()
    assert 40 < first < 40 + params.window + params.linger_steps + 2


def test_a_target_that_never_moved_is_not_suspect():
    watch, events = watch_path(np.zeros((60, 1, 2)))
    assert not watch.suspect.any() and not events


def test_lingering_with_an_unconfident_position_estimate_is_not_trusted():
    steps = np.arange(80)
    lure = np.stack([np.minimum(steps, 40) * 0.03, np.zeros(80)], axis=1)[:, None, :]
    watch, _ = watch_path(lure, std=1.0)
    assert not watch.suspect.any()


def test_a_target_at_a_known_zone_edge_becomes_suspect_and_a_far_one_does_not():
    zone = sensing_table([sensing_row([0.0, 0.0], np.eye(2) * 0.1, r_safe=1.0, beta=1.0)])
    margin = LureGuardParams().zone_margin
    positions = np.array([[1.0 + 0.5 * margin, 0.0], [2.5, 0.0]])
    watch, events = watch_path(positions[None], zone_rows=zone)
    assert watch.suspect[:, 0].all() and not watch.suspect[:, 1].any()
    assert {e.cause for e in events} == {"zone"}


def test_suspicion_lasts_and_each_league_keeps_its_own():
    watch = SuspectWatch(3, LureGuardParams(), DT)
    zone = sensing_table([sensing_row([0.0, 0.0], np.eye(2) * 0.1, r_safe=1.0, beta=1.0)])
    watch.observe(0, [0, 1], estimate(np.array([[0.5, 0.0]])), zone)
    assert watch.suspect[[0, 1], 0].all() and not watch.suspect[2, 0]
    # away from the zone later: still suspect; a merge shares it without a new event
    watch.observe(1, [0, 1], estimate(np.array([[3.0, 0.0]])), zone)
    events = watch.observe(2, [0, 1, 2], estimate(np.array([[3.0, 0.0]])), zone)
    assert watch.suspect[:, 0].all() and not events
    rows = watch.rows([2], estimate(np.array([[3.0, 0.0]])), beta=1.0)
    assert len(rows) == 1 and rows[0, 5] == LureGuardParams().standoff


# ---------------------------------------------------------------------------- episodes


def stopping_target_scenario(**lure: Any):
    """A target that walks 1.5 m east and stops; robots start near it."""
    return parse_scenario(
        {
            "name": "stopping-target",
            "seed": 3,
            "steps": 110,
            "dt": DT,
            "workspace": {"xmin": -4, "xmax": 4, "ymin": -3, "ymax": 3},
            "robots": [{"start": [-1.5, 0.6]}, {"start": [-1.5, -0.6]}],
            "targets": [
                {
                    "start": [-1.0, 0.0],
                    "motion": {"type": "waypoints", "points": [[0.5, 0.0]], "speed": 0.3},
                }
            ],
            "zones": [],
            "guards": {"lure": lure},
        }
    )


def closest_approach(result, after: int) -> float:
    robots = result["robots"]
    target = result["targets"].set_index("step")
    late = robots[robots.step >= after]
    gaps = np.hypot(
        late.x.to_numpy() - target.loc[late.step, "x"].to_numpy(),
        late.y.to_numpy() - target.loc[late.step, "y"].to_numpy(),
    )
    return float(gaps.min())


def test_with_the_lure_guard_robots_keep_their_standoff_from_a_suspect_target():
    standoff = LureGuardParams().standoff
    guarded = run_episode(stopping_target_scenario(enabled=True))
    plain = run_episode(stopping_target_scenario())
    events = guarded["events"]
    suspected = events[events.event == "target_suspected"]
    assert len(suspected) and set(suspected.cause) == {"linger"}
    after = int(suspected.step.min()) + 30  # time to back off
    assert closest_approach(guarded, after) > 0.8 * standoff
    assert closest_approach(plain, after) < 0.5 * standoff


def test_lure_guard_off_leaves_the_episode_unchanged():
    base = run_episode(stopping_target_scenario())
    tuned = run_episode(stopping_target_scenario(standoff=3.0, linger_steps=1))
    for name in ("robots", "targets", "events"):
        pd.testing.assert_frame_equal(base[name], tuned[name])
