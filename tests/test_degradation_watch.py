"""The degradation watch of the failure-aware policy (docs/model.md §6.4): a robot's silently
degraded sensor found from its own measurements against its league's prediction, its noise
re-estimated and used by the filter, a zone learned where it was found; off by default."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pandas as pd
import pytest
from joblib import Parallel, delayed
from scipy.stats import chi2

from helpers import healthy_observation, shipped
from resilient_tracking.belief.degradation_watch import DegradationWatch, DegradationWatchSettings
from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.needs import BeliefNeeds
from resilient_tracking.belief.settings import BeliefSettings
from resilient_tracking.belief.team_belief import TeamBelief
from resilient_tracking.events import EVENT_NAMES, TRUTH_EVENTS
from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.range_bearing import RangeBearingSensor
from resilient_tracking.models.sensor import wrap_angle
from resilient_tracking.observation import TeamObservation
from resilient_tracking.scenario import Scenario
from resilient_tracking.scenario.overrides import overridden
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.team import Team

WATCH_PARAMS = "belief.degradation_watch"
WATCH = f"{WATCH_PARAMS}.enabled"
SEEDS = range(101, 111)
SENSOR = RangeBearingSensor()
#: four robots around the origin, 2.5 m out, watching targets near it
ROBOTS = 2.5 * np.array([[np.cos(a), np.sin(a)] for a in 0.4 + np.arange(4) * np.pi / 2])


# --------------------------------------------------------------------------- the filter


def test_a_scaled_noise_is_the_filter_of_a_noisier_sensor() -> None:
    """``noise_scale[k] = λ`` updates exactly as a sensor whose information peaks are 1/λ."""
    rng = np.random.default_rng(5)
    model = NearlyConstantVelocity(0.1, 0.2)
    est = TargetEstimate.initial(rng.normal(size=(3, 4)), 0.4, 0.2)
    z = SENSOR.sample(ROBOTS[:2, None, :], est.mean[None, :, :2], rng)
    ekf = ExtendedKalmanFilter(model, SENSOR)
    noisy = RangeBearingSensor(range_peak=15.0 / 25.0, bearing_peak=15.0 / 25.0)
    scaled = ekf.update(est, ROBOTS[:2], z, noise_scale=np.array([25.0, 25.0]))
    expected = ExtendedKalmanFilter(model, noisy).update(est, ROBOTS[:2], z)
    np.testing.assert_allclose(scaled.mean, expected.mean, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(scaled.cov, expected.cov, rtol=1e-12, atol=1e-12)
    one = ekf.update(est, ROBOTS[:2], z, noise_scale=np.array([25.0, 1.0]))
    assert not np.allclose(one.mean, scaled.mean)  # per robot
    nominal = ekf.update(est, ROBOTS[:2], z, noise_scale=np.ones(2))
    assert np.array_equal(nominal.mean, ekf.update(est, ROBOTS[:2], z).mean)
    assert not np.allclose(nominal.mean, scaled.mean)


# --------------------------------------------------------------------------- the watch alone


def _watched_run(
    steps: int, onset: int | None, factor: float, seed: int, adapt: bool = True
) -> tuple[TeamBelief, list[Any], np.ndarray]:
    """Four robots, three targets near the origin, robot 0's noise times ``factor`` from step
    ``onset`` (None: never); returns the belief, every event and the per-step position NEES."""
    rng = np.random.default_rng(seed)
    model = NearlyConstantVelocity(0.1, 0.05)
    chol_q = np.linalg.cholesky(model.process_noise)
    x = np.column_stack([rng.normal(0, 0.3, (3, 2)), rng.normal(0, 0.05, (3, 2))])
    belief = TeamBelief(
        4,
        TargetEstimate.initial(x + rng.normal(0, [0.3, 0.3, 0.1, 0.1], x.shape), 0.3, 0.1),
        ExtendedKalmanFilter(model, SENSOR),
        BeliefNeeds(zones=True),
        settings=BeliefSettings(degradation_watch=DegradationWatchSettings(enabled=adapt)),
        sensor=SENSOR,
    )
    events: list[Any] = []
    nees = np.empty(steps)
    for t in range(steps):
        x = x @ model.transition.T + rng.standard_normal(x.shape) @ chol_q.T
        x[:, :2] = np.clip(x[:, :2], -1.0, 1.0)  # keep the targets among the robots
        clean = SENSOR.predict(ROBOTS[:, None, :], x[None, :, :2])
        std = np.sqrt(SENSOR.noise_variance(clean[..., 0]))
        gain = np.ones((4, 1, 1))
        if onset is not None and t >= onset:
            gain[0] = factor
        z = clean + gain * std * rng.standard_normal(clean.shape)
        z[..., 1] = wrap_angle(z[..., 1])
        events += belief.update(_observation(t, z))
        est = belief.estimates[0]
        err = x[:, :2] - est.mean[:, :2]
        nees[t] = (
            np.einsum("ni,ni->", err, np.linalg.solve(est.cov[:, :2, :2], err[..., None])[..., 0])
            / 3
        )
    return belief, events, nees


def _observation(step: int, z: np.ndarray) -> TeamObservation:
    """The four robots of ``ROBOTS``, all sensing and linked, measuring ``z``."""
    return healthy_observation(step, ROBOTS, z, ~np.eye(4, dtype=bool))


def test_a_fivefold_noise_is_found_within_a_few_steps_and_estimated_near_five() -> None:
    belief, events, nees = _watched_run(600, onset=200, factor=5.0, seed=11)
    found = [e for e in events if e.event == "degradation_detected"]
    assert [e.robot for e in found] == [0]
    assert 200 <= found[0].step <= 205
    watch = belief.degradation_watch
    assert watch is not None
    assert 4.5 <= watch.factor()[0] <= 5.5
    assert np.all(watch.factor()[1:] == 1.0)
    assert 0.95 < watch.attacked_fraction()[0] < 1.0
    # a sensing zone where robot 0 found it, learned by robot 0 (shared at the next tick)
    zones = belief.knowledge[0].of_kind("sensing")
    assert [z.source for z in zones] == ["degradation"]
    np.testing.assert_allclose(zones[0].mean, ROBOTS[0])


def test_the_adapted_filter_stays_consistent_where_the_nominal_one_does_not() -> None:
    """Position NEES (χ²(2) per target) over the 400 steps after the onset, three targets: the
    watched filter inside the 95 % band of the time average, the nominal one far above."""
    _, _, watched = _watched_run(600, onset=200, factor=5.0, seed=12)
    _, _, nominal = _watched_run(600, onset=200, factor=5.0, seed=12, adapt=False)
    lo, hi = chi2.ppf([0.025, 0.975], 2 * 3 * 40) / (3 * 40)  # ~40 independent windows
    assert lo <= watched[220:].mean() <= hi, watched[220:].mean()
    assert nominal[220:].mean() > 2 * hi


def test_a_league_with_a_robot_found_degraded_updates_with_the_iterated_second_order_ekf() -> None:
    """After a detection the league's update linearises five times with the second-order noise
    term, its degraded robot's noise scaled; the estimator's own update gives other numbers."""
    belief, events, _ = _watched_run(210, onset=200, factor=5.0, seed=11)
    assert [e.robot for e in events if e.event == "degradation_detected"] == [0]
    prior = belief.predicted(0)
    rng = np.random.default_rng(3)
    z = SENSOR.sample(ROBOTS[:, None, :], prior.mean[None, :, :2], rng)
    after = copy.deepcopy(belief)
    after.update(_observation(210, z))
    assert after.degradation_watch is not None
    scale = after.degradation_watch.noise_scale([0, 1, 2, 3])
    assert scale is not None and scale[0] > 1.0 and np.all(scale[1:] == 1.0)
    model = NearlyConstantVelocity(0.1, 0.05)
    careful = ExtendedKalmanFilter(model, SENSOR, iterations=5, second_order=True)
    expected = careful.update(prior, ROBOTS, z, noise_scale=scale)
    np.testing.assert_array_equal(after.estimates[0].mean, expected.mean)
    np.testing.assert_array_equal(after.estimates[0].cov, expected.cov)
    own = ExtendedKalmanFilter(model, SENSOR).update(prior, ROBOTS, z, noise_scale=scale)
    assert np.abs(own.mean - expected.mean).max() > 1e-9


def test_a_known_noise_is_adopted_as_one_detection_and_then_followed() -> None:
    """What a reference that knows the true noise hands the watch: the first scale is a
    detection (event and zone clue), later ones only replace the scale."""
    model = NearlyConstantVelocity(0.1, 0.05)
    belief = TeamBelief(
        4,
        TargetEstimate.initial(np.zeros((3, 4)), 0.3, 0.1),
        ExtendedKalmanFilter(model, SENSOR),
        BeliefNeeds(zones=True),
        settings=BeliefSettings(degradation_watch=DegradationWatchSettings(enabled=True)),
        sensor=SENSOR,
    )
    watch = belief.degradation_watch
    assert watch is not None
    events = watch.adopt(belief, 50, 2, ROBOTS[2], 25.0)
    assert [e.event for e in events] == ["degradation_detected"] and watch.detected_step[2] == 50
    assert watch.factor()[2] == 5.0 and np.all(watch.factor()[[0, 1, 3]] == 1.0)
    assert watch.adopt(belief, 51, 2, ROBOTS[2], 16.0) == [] and watch.factor()[2] == 4.0
    assert [z.source for z in belief.knowledge[2].of_kind("sensing")] == ["degradation"]


def test_no_false_alarm_on_nominal_sensors() -> None:
    """4 robots × 3000 steps of nominal measurements: no detection."""
    belief, events, _ = _watched_run(3000, onset=None, factor=1.0, seed=13)
    assert not [e for e in events if e.event == "degradation_detected"]
    assert belief.degradation_watch is not None
    assert np.all(belief.degradation_watch.scale == 1.0)


def test_a_detection_needs_the_threshold() -> None:
    """The same onset against a threshold no evidence reaches: never found."""
    watch = DegradationWatch(1, DegradationWatchSettings(threshold=1e4, warmup=0), SENSOR)
    est = TargetEstimate.initial(np.zeros((1, 4)), 0.1, 0.1)
    z = SENSOR.predict(ROBOTS[:1, None, :], est.mean[None, :, :2]) + 5.0
    for step in range(50):
        assert watch.observe(_NoLearning(), step, [0], est, ROBOTS[:1], z) == []
    assert watch.cusum[0] > 100


class _NoLearning:
    def league_knowledge(self, league: list[int]) -> Any:
        raise AssertionError("not asked")

    def learn(self, robot: int, estimate: Any) -> None:
        raise AssertionError("nothing to learn")


# --------------------------------------------------------------------------- the option


def test_the_watch_is_off_by_default_and_declared_as_a_team_event() -> None:
    assert BeliefSettings().degradation_watch.enabled is False
    team = Team.from_scenario(shipped("sensing-degrade"), np.zeros((3, 4)))
    assert team.belief.degradation_watch is None
    assert "degradation_detected" in EVENT_NAMES
    assert "degradation_detected" not in TRUTH_EVENTS


def _tables(scenario: Scenario, seed: int) -> dict[str, pd.DataFrame]:
    result = run_episode(scenario, seed=seed)
    return {k: result.tables[k] for k in ("team", "robots", "targets", "events", "knowledge")}


def test_the_watch_switched_off_changes_nothing_whatever_its_settings() -> None:
    base = shipped("sensing-degrade").with_overrides(steps=160)
    off = overridden(
        base,
        {
            "belief.degradation_watch.threshold": 1.0,
            "belief.degradation_watch.zone_std": 2.0,
        },
    )
    a, b = _tables(base, 103), _tables(off, 103)
    for name in a:
        pd.testing.assert_frame_equal(a[name], b[name], check_exact=True)


def test_a_watched_run_is_deterministic() -> None:
    scenario = overridden(shipped("sensing-degrade").with_overrides(steps=180), {WATCH: True})
    a, b = _tables(scenario, 101), _tables(scenario, 101)
    for name in a:
        pd.testing.assert_frame_equal(a[name], b[name], check_exact=True)
    assert (a["events"].event == "degradation_detected").any()


# --------------------------------------------------------------------------- sensing-degrade


def _mission(settings: dict[str, Any]) -> pd.DataFrame:
    """Per seed of sensing-degrade run by the team route (the EKF) with these settings: onsets
    (truth), detections (team), NEES, MSE."""
    scenario = overridden(shipped("sensing-degrade").with_team("route"), settings)
    rows = []
    for seed in SEEDS:
        tables = run_episode(scenario, seed=seed).tables
        t, ev = tables["targets"], tables["events"]
        nees = ((t.x - t.est_x) ** 2 / t.var_x + (t.y - t.est_y) ** 2 / t.var_y).mean()
        mse = ((t.x - t.est_x) ** 2 + (t.y - t.est_y) ** 2).mean()
        onset = {int(r.robot): int(r.step) for r in ev[ev.event == "degraded"].itertuples()}
        found = {
            int(r.robot): int(r.step) for r in ev[ev.event == "degradation_detected"].itertuples()
        }
        delays = [found[i] - s for i, s in onset.items() if i in found and found[i] >= s]
        false = [i for i, s in found.items() if i not in onset or s < onset[i]]
        missed = [i for i in onset if i not in found]
        learned = tables["knowledge"]
        rows.append(
            dict(
                seed=seed,
                nees=nees,
                mse=mse,
                delays=delays,
                false=len(false),
                missed=len(missed),
                zones=int((learned.source == "degradation").sum()) if len(learned) else 0,
            )
        )
    return pd.DataFrame(rows)


@pytest.fixture(scope="module")
def missions() -> dict[str, pd.DataFrame]:
    # the watch with the estimator's own update (one linearisation, no second-order term)
    plain = {
        WATCH: True,
        f"{WATCH_PARAMS}.update_iterations": 1,
        f"{WATCH_PARAMS}.second_order": False,
    }
    return {"paper": _mission({}), "watch": _mission({WATCH: True}), "plain": _mission(plain)}


def test_degradations_are_found_fast_and_only_where_they_happened(missions) -> None:
    watch = missions["watch"]
    delays = [d for row in watch.delays for d in row]
    assert len(delays) >= 20
    assert np.median(delays) <= 20  # measured: 1 step
    # measured: no false alarm in ten runs, no degradation missed
    assert watch.false.sum() <= 1 and watch.missed.sum() == 0
    assert (watch.zones > 0).all()  # each run's league learned where
    assert (missions["paper"].delays.map(len) == 0).all()  # the paper's team never notices


def test_the_watch_brings_the_nees_down_from_the_paper_teams(missions) -> None:
    """Measured: 2.8 with the watch, 64 for the paper's team (χ²(2): 2)."""
    assert missions["paper"].nees.mean() > 30
    assert missions["watch"].nees.mean() < 5


def test_the_careful_update_tracks_a_degraded_team_better_than_the_first_order_one(
    missions,
) -> None:
    """Measured: mean position MSE 0.035 against 0.100 with the estimator's own update (one
    linearisation, no second-order term), lower in 8 of 10 seeds."""
    careful, plain = missions["watch"], missions["plain"]
    assert careful.mse.mean() < 0.7 * plain.mse.mean()
    assert (careful.mse.to_numpy() < plain.mse.to_numpy()).sum() >= 7


@pytest.mark.xfail(
    strict=True,
    reason="NEES 2.80 against the band's 2.73: the watched team is slightly overconfident "
    "(the paper's team: 64)",
)
def test_the_watched_team_nees_is_inside_its_band_on_sensing_degrade(missions) -> None:
    lo, hi = chi2.ppf([0.025, 0.975], 2 * 30) / 30  # 10 seeds × 3 targets
    assert lo <= missions["watch"].nees.mean() <= hi


# --------------------------------------------------------------------------- zone-free runs


def _alarms(scenario: Scenario, seed: int) -> int:
    ev = run_episode(scenario, seed=seed).tables["events"]
    return int((ev.event == "degradation_detected").sum())


def _false_alarms(names: tuple[str, ...], seeds: range, jobs: int = 1) -> tuple[int, int]:
    """Degradation alarms and robot-steps over the zone-free missions, ``jobs`` processes."""
    scenarios = [overridden(shipped(name), {WATCH: True, "zones": []}) for name in names]
    runs = [(scenario, seed) for scenario in scenarios for seed in seeds]
    alarms = Parallel(n_jobs=jobs)(delayed(_alarms)(scenario, seed) for scenario, seed in runs)
    return sum(alarms), sum(len(scenario.robots) * scenario.steps for scenario, _ in runs)


@pytest.mark.slow
def test_at_most_one_false_alarm_per_ten_thousand_robot_steps() -> None:
    """The paper's missions, the benchmarks, an evasive mission and the degrading-sensor
    mission, zones removed, four seeds: more than 40 000 robot-steps."""
    names = (
        "sensing-temp",
        "sensing-perm",
        "comm-temp",
        "comm-perm",
        "combined-temp",
        "combined-perm",
        "bench-risk",
        "bench-complex",
        "evasive-open",
        "sensing-degrade",
    )
    alarms, robot_steps = _false_alarms(names, SEEDS[:4], jobs=2)
    assert robot_steps >= 40_000
    assert alarms <= robot_steps / 10_000
