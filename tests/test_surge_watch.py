"""The lure guard's surge cue: a steady target that speeds up well beyond its usual speed is
suspect until it is back at that speed; corners, unsteady targets and new ones are not."""

from __future__ import annotations

import numpy as np

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.planning.layout import sensing_table
from resilient_tracking.policies.guards.lure import LureGuardParams
from resilient_tracking.policies.guards.surge_watch import SurgeWatch
from resilient_tracking.policies.guards.suspects import SuspectWatch

DT = 0.1
PARAMS = LureGuardParams()


def heading(degrees: float, speed: float) -> np.ndarray:
    """The velocity of ``speed`` towards ``degrees``."""
    angle = np.radians(degrees)
    return speed * np.array([np.cos(angle), np.sin(angle)])


def feed(velocities: list[np.ndarray]) -> tuple[SurgeWatch, list[int], list[bool]]:
    """One target's velocities, tick by tick, to a watch of two robots in one league; the
    ticks at which a surge started and whether it was surging after each tick."""
    watch = SurgeWatch(2, PARAMS, DT)
    started, surging = [], []
    for tick, velocity in enumerate(velocities):
        if watch.observe([0, 1], velocity[None], np.array([True]))[0]:
            started.append(tick)
        surging.append(bool(watch.surging[0, 0]))
    return watch, started, surging


def test_a_steady_target_that_speeds_up_surges_until_it_is_back_at_its_usual_speed():
    lane, trip = heading(0.0, 0.18), heading(25.0, 0.3)
    velocities = [lane] * 60 + [trip] * 100 + [heading(0.0, 0.0)] * 50 + [lane] * 60
    watch, started, surging = feed(velocities)
    assert started == [60 + PARAMS.surge_steps - 1]
    # stopping at the danger keeps it surging; back on its lane, the surge ends
    assert all(surging[started[0] : 210])
    assert not surging[-1] and surging.index(False, started[0]) == 210 + PARAMS.calm_steps - 1
    assert (watch.surging[0] == watch.surging[1]).all()  # shared within the league


def test_a_slow_speed_up_over_the_window_is_still_a_surge():
    # the speed over the window climbs from the lane's to the trip's over 8 s: slower than
    # the usual speed's running mean lags behind by a whole surge
    ramp = [heading(0.0, 0.18 + 0.15 * k / 80) for k in range(80)]
    velocities = [heading(0.0, 0.18)] * 40 + ramp + [heading(0.0, 0.33)] * 60
    watch, started, _ = feed(velocities)
    assert len(started) == 1 and 40 < started[0] < 120 + PARAMS.surge_steps
    assert watch.usual[0, 0] < 0.18 + PARAMS.surge / 2


def test_a_league_keeps_the_surge_a_member_saw_and_the_longest_record():
    watch = SurgeWatch(2, PARAMS, DT)
    one = np.array([True])
    for _ in range(40):  # robot 1 alone watches the target on its lane, then speeding up
        watch.observe([1], heading(0.0, 0.18)[None], one)
    for _ in range(PARAMS.surge_steps):
        watch.observe([1], heading(0.0, 0.3)[None], one)
    assert watch.surging[1, 0] and not watch.surging[0, 0]
    watch.observe([0, 1], heading(0.0, 0.3)[None], one)  # robot 0, which saw nothing, joins
    assert watch.surging[:, 0].all()
    assert (watch.usual[:, 0] == 0.18).all() and (watch.watched[:, 0] == 40 + 10 + 1).all()


def test_turning_a_corner_at_the_same_speed_is_no_surge():
    velocities = [heading(0.0, 0.18)] * 60 + [heading(60.0, 0.18)] * 100
    _, started, _ = feed(velocities)
    assert not started


def test_an_unsteady_target_is_no_surge():
    rng = np.random.default_rng(0)
    # fleeing robots: a new direction every tick, then faster
    velocities = [heading(rng.uniform(0, 360), 0.2) for _ in range(60)]
    velocities += [heading(rng.uniform(0, 360), 0.4) for _ in range(60)]
    _, started, _ = feed(velocities)
    assert not started


def test_a_target_surges_only_once_watched_for_the_usual_memory_but_may_set_off_before():
    watched = round(PARAMS.usual_memory / DT)  # ticks, the first one included
    late = [heading(0.0, 0.18)] * watched + [heading(0.0, 0.3)] * 100
    _, started, _ = feed(late)
    assert started == [watched + PARAMS.surge_steps - 1]
    # setting off while still watched: the trip's speed does not become the usual one
    early = [heading(0.0, 0.18)] * (watched // 3) + [heading(0.0, 0.3)] * 100
    watch, started, _ = feed(early)
    assert started == [watched - 1 + PARAMS.surge_steps - 1]
    assert watch.usual[0, 0] == 0.18
    # a target as fast from its first tick on: that is its usual speed
    _, started, _ = feed([heading(0.0, 0.3)] * 100)
    assert not started


def test_untrusted_ticks_change_nothing():
    watch = SurgeWatch(1, PARAMS, DT)
    for _ in range(100):
        watch.observe([0], np.full((1, 2), np.nan), np.array([False]))
    assert np.isnan(watch.usual).all() and not watch.watched.any() and not watch.surging.any()


def estimate(positions: np.ndarray) -> TargetEstimate:
    n = len(positions)
    mean = np.zeros((n, 4))
    mean[:, :2] = positions
    return TargetEstimate(mean, np.tile(np.diag([0.05**2, 0.05**2, 0.04, 0.04]), (n, 1, 1)))


def test_the_lure_guard_keeps_robots_off_a_surging_target_only_while_it_surges():
    # positions: 8 s along a lane at 0.18 m/s, 6 s off it at 0.3 m/s, then back at 0.18 m/s
    speeds = [0.18] * 80 + [0.3] * 60 + [0.18] * 160
    x = np.concatenate([[0.0], np.cumsum(np.array(speeds) * DT)])
    watch = SuspectWatch(2, PARAMS, DT)
    causes, guarded = [], []
    for step, xi in enumerate(x):
        now = estimate(np.array([[xi, 0.0]]))
        causes += [e.cause for e in watch.observe(step, [0, 1], now, sensing_table())]
        guarded.append(len(watch.rows([0], now, beta=1.0)))
    assert set(causes) == {"surge"}
    first = guarded.index(1)
    assert 80 < first < 80 + PARAMS.window + PARAMS.surge_steps
    assert guarded[-1] == 0 and not watch.suspect.any()  # the surge ended; no lasting suspicion
