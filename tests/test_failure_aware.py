"""Scenario-level behaviour of the failure-aware policy (paper Alg. 1–4, docs/model.md §6)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from helpers import shipped
from resilient_tracking.belief.circle_fit import fit_circle
from resilient_tracking.build import team_config
from resilient_tracking.planning.adaptation import adaptive_weights
from resilient_tracking.policies import FailureAwarePolicy
from resilient_tracking.policies.failure_aware_params import FailureAwareParams
from resilient_tracking.policies.guards import ExposureGuard, GuardsSpec
from resilient_tracking.scenario import parse_scenario
from resilient_tracking.scenario.overrides import every_zone_known, overridden
from resilient_tracking.sim.episode import initial_estimate, run_episode
from resilient_tracking.team import Team
from resilient_tracking.world import World

STILL = {"type": "constant_velocity", "velocity": [0.0, 0.0]}

#: the guards on by default that the paper's team has not
PAPER_OFF = ("comm_hazard", "last_sensors", "safe_circling")


def scenario(**overrides: Any):
    """Four-by-six workspace, three robots on the left, still targets, the paper's method at its
    fixed risk levels (team route); override anything."""
    data: dict[str, Any] = {
        "name": "test",
        "team": "route",
        "seed": 1,
        "steps": 120,
        "workspace": {"xmin": -5, "xmax": 5, "ymin": -4, "ymax": 4},
        "robots": [{"start": [-3.0, 1.0]}, {"start": [-3.0, 0.0]}, {"start": [-3.0, -1.0]}],
        "targets": [{"start": [-2.0, 0.5], "motion": STILL}],
        "zones": [],
        "policy": {"name": "failure_aware"},
    }
    data.update(overrides)
    return parse_scenario(data)


def disk_comm_zone(mu, persistence: str, p_hit: float = 1.0) -> dict[str, Any]:
    """A comm zone that hits a robot inside it at the first activation tick."""
    return {
        "kind": "comm",
        "mu": list(mu),
        "sigma": [[0.05, 0.0], [0.0, 0.05]],
        "delta2": 0.01,
        "persistence": persistence,
        "hazard": {"model": "disk", "f_act": 1.0, "p_hit": p_hit},
    }


def run_with_policy(s, seed: int = 1):
    """The episode loop by hand, keeping the policy to look at its weights."""
    world = World(s, seed)
    config = team_config(s)
    policy = FailureAwarePolicy(config, s.policy.params_for("failure_aware"))
    team = Team(policy, initial_estimate(s, world, seed))
    weights, modes, attacked, attacks = [], [], [], []
    for _ in range(s.steps):
        obs = world.observe()
        out = team.step(obs)
        weights.append(policy.last_weights.copy())
        modes.append(list(out.decision.modes))
        attacked.append(int(np.sum(~obs.sensing_ok | ~obs.comm_ok)))
        attacks.append(obs.attacks)
        world.step(out.controls)
    return np.array(weights), modes, np.array(attacked), attacks


# ---------------------------------------------------------------------------- sensing


@pytest.mark.slow
def test_zone_is_known_to_every_league_member_in_the_step_it_is_revealed():
    result = run_episode(shipped("sensing-temp"), policy="failure_aware", seed=1)
    events, knowledge, robots = result["events"], result["knowledge"], result["robots"]
    first = events[events.event == "attack"].iloc[0]
    step, victim = int(first.step), int(first.robot)
    league = robots[(robots.step == step) & (robots.robot == victim)].league.item()
    members = robots[(robots.step == step) & (robots.league == league)].robot.tolist()
    assert len(members) == 3
    learned = knowledge[(knowledge.step == step) & (knowledge.zone == 0)]
    assert sorted(learned.robot) == members
    assert learned[learned.robot == victim].source.item() == "attack"
    assert set(learned[learned.robot != victim].source) == {"broadcast"}
    assert not len(knowledge[knowledge.step < step])  # nothing known before the attack


def test_adaptive_weights_interpolate_between_risky_and_safe():
    p = FailureAwareParams()
    risky, safe = p.risky.as_array(), p.safe.as_array()
    np.testing.assert_allclose(adaptive_weights(risky, safe, 0, 3), risky)
    np.testing.assert_allclose(adaptive_weights(risky, safe, 3, 3), safe)
    np.testing.assert_allclose(adaptive_weights(risky, safe, 1, 3), risky - (risky - safe) / 3)
    # more attacked robots: closer to safe in every weight that differs
    w1, w2 = adaptive_weights(risky, safe, 1, 3), adaptive_weights(risky, safe, 2, 3)
    differs = risky != safe
    assert np.all(np.abs(w2 - safe)[differs] < np.abs(w1 - safe)[differs])


def test_weights_follow_attacks_and_cooldown_lasts_exactly_its_length():
    s = shipped("sensing-temp")
    p = s.policy.params_for("failure_aware")
    weights, modes, attacked, attacks = run_with_policy(s)
    attack_steps = [k for k, a in enumerate(attacks) if a]
    assert attack_steps, "the scenario must produce a temporary attack"
    cooling = np.zeros(len(modes), bool)
    for k in attack_steps:
        cooling[k : k + p.cooldown_steps] = True
    for k, row in enumerate(modes):
        league_rows = [i for i, m in enumerate(row) if m in ("league", "cooldown")]
        if not league_rows:
            continue
        if cooling[k]:
            assert {row[i] for i in league_rows} == {"cooldown"}, k
            np.testing.assert_allclose(
                weights[k, league_rows], np.tile(p.cooldown.as_array(), (len(league_rows), 1))
            )
        else:
            assert {row[i] for i in league_rows} == {"league"}, k
            expected = adaptive_weights(p.risky.as_array(), p.safe.as_array(), int(attacked[k]), 3)
            np.testing.assert_allclose(
                weights[k, league_rows], np.tile(expected, (len(league_rows), 1))
            )
    # the cool-down ends exactly cooldown_steps after the last attack that started one
    last = attack_steps[-1]
    if last + p.cooldown_steps < len(modes):
        assert "cooldown" not in modes[last + p.cooldown_steps]
    # after the recovery and the cool-down the team is back to the risky weights
    calm = [k for k in range(last, len(modes)) if not attacked[k] and not cooling[k]]
    assert calm
    np.testing.assert_allclose(weights[calm[0], 0], p.risky.as_array())


def test_weights_move_toward_safe_while_robots_stay_attacked():
    s = shipped("sensing-perm")
    p = s.policy.params_for("failure_aware")
    weights, modes, attacked, _ = run_with_policy(s)
    assert attacked.max() >= 1
    for k in np.flatnonzero(attacked):
        expected = adaptive_weights(p.risky.as_array(), p.safe.as_array(), int(attacked[k]), 3)
        working = [i for i, m in enumerate(modes[k]) if m == "league"]
        np.testing.assert_allclose(weights[k, working], np.tile(expected, (len(working), 1)))
    assert weights[np.flatnonzero(attacked)[-1], :, 2].max() > p.risky.as_array()[2]


# ---------------------------------------------------------------------------- comm, permanent


def circling_scenario(infer: bool):
    """Robot 0 starts on a comm jammer that destroys its radio at step 10; the targets
    later lead its teammates across that zone. Robot 0 lingers there, far from every target,
    as the paper's one-step program lets it (the route program heads for a target at once
    and would leave the jammer before its first activation tick)."""
    fit = {} if infer else {"min_samples": 10_000, "window": 10_000}
    guess = {} if infer else {"provisional_zone": {"enabled": False}}
    slow = {"type": "waypoints", "speed": 0.25}
    return scenario(
        steps=260,
        robots=[{"start": [0.0, 0.0]}, {"start": [-3.0, 1.2]}, {"start": [-3.0, -1.2]}],
        targets=[
            {"start": [-2.6, 0.8], "motion": {**slow, "points": [[-2.4, 0.6], [2.5, 0.4]]}},
            {"start": [-2.6, -0.8], "motion": {**slow, "points": [[-2.4, -0.6], [2.5, -0.2]]}},
        ],
        zones=[disk_comm_zone([0.0, 0.0], "permanent")],
        belief={"circle_fit": fit, **guess},
        planner={"program": "one_step"},
    )


@pytest.mark.slow
def test_permanent_comm_failure_circles_and_teammates_infer_the_zone():
    s = circling_scenario(infer=True)
    result = run_episode(s, seed=1)
    events, robots = result["events"], result["robots"]
    hit = events[(events.event == "attack") & (events.robot == 0)]
    assert len(hit) == 1 and hit.persistence.item() == "permanent"
    k0 = int(hit.step.item())
    r0 = robots[robots.robot == 0]
    assert set(r0[r0.step > k0]["mode"]) == {"circular"}
    # the path is a clean circle around the attacker's estimated center (its clue: mu)
    path = r0[r0.step > k0 + 15][["x", "y"]].to_numpy()
    fit = fit_circle(path)
    assert fit is not None
    assert fit.residual < 0.02
    assert np.linalg.norm(fit.center - np.array(s.zones[0].mu)) < 0.05
    assert np.abs(np.diff(path, axis=0)).max() <= 0.1 + 1e-9  # velocity bounds
    # a teammate infers the zone within a bounded time, near the circled center
    inferred = events[events.event == "zone_inferred"]
    assert len(inferred) == 1
    assert int(inferred.step.item()) - k0 <= 60
    knowledge = result["knowledge"]
    circle = knowledge[knowledge.source == "circle"]
    assert set(circle.robot) == {1, 2}
    center = circle[["x", "y"]].to_numpy()[0]
    assert np.linalg.norm(center - np.array(s.zones[0].mu)) < 0.15
    # before the fit, the league kept clear of a provisional zone where robot 0 fell silent
    suspected = events[events.event == "zone_suspected"]
    assert list(suspected.robot) == [0] and int(suspected.step.item()) <= k0 + 1
    guess = knowledge[knowledge.source == "silence"]
    assert set(guess.robot) == {1, 2} and (guess.step < int(inferred.step.item())).all()


def test_with_signal_turns_a_robot_circles_its_attacker_once_then_tracks_alone():
    """The circle is the signal (Alg. 3 reads it); after one turn around the attacker the
    robot, whose sensor works, plans alone with its tracking term instead of circling on."""
    s = overridden(circling_scenario(infer=True), {"guards.signal_turns.enabled": True})
    result = run_episode(s, seed=1)
    events, robots = result["events"], result["robots"]
    hit = events[(events.event == "attack") & (events.robot == 0)]
    k0 = int(hit.step.item())
    r0 = robots[(robots.robot == 0) & (robots.step > k0)]
    circling = r0[r0["mode"] == "circular"].step.to_numpy()
    alone = r0[r0["mode"] == "individual"].step.to_numpy()
    assert len(circling) and len(alone) and set(r0["mode"]) == {"circular", "individual"}
    assert circling.max() < alone.min() and alone.max() == robots.step.max()  # then for good
    # one turn around the attacker's estimate (its clue: mu) before tracking
    path = robots[(robots.robot == 0) & robots.step.between(k0, alone.min())]
    offset = path[["x", "y"]].to_numpy() - np.array(s.zones[0].mu)
    swept = np.abs(np.angle(np.exp(1j * np.diff(np.arctan2(offset[:, 1], offset[:, 0]))))).sum()
    assert 2 * np.pi <= swept <= 2 * np.pi + 0.5
    # the teammates still read the circle, before the robot leaves it
    inferred = events[events.event == "zone_inferred"]
    assert len(inferred) == 1 and int(inferred.step.item()) <= circling.max()


def test_a_robot_whose_radio_a_known_zone_destroys_circles_it_too():
    """The zone is on the team's map from step 0 (``known``); its attack clue still tells the
    victim which zone struck it, so it circles that zone (Alg. 4) as without the map."""
    s = circling_scenario(infer=False)
    s = every_zone_known(s)
    # the paper's constraint set: the league does not keep clear of the known zone's hazard
    s = overridden(s, {f"guards.{g}.enabled": False for g in PAPER_OFF})
    result = run_episode(s, seed=1)
    events, robots = result["events"], result["robots"]
    hit = events[(events.event == "attack") & (events.robot == 0)]
    assert len(hit) == 1 and "permanent" in hit.detail.item()
    k0 = int(hit.step.item())
    learned = events[(events.event == "zone_learned") & (events.robot == 0)]
    assert list(learned.detail) == ["zone0 comm via broadcast", "zone0 comm via attack"]
    r0 = robots[robots.robot == 0]
    assert set(r0[r0.step > k0]["mode"]) == {"circular"}


def _time_near(result, robots_of_interest, center, radius, after):
    r = result["robots"]
    r = r[r.robot.isin(robots_of_interest) & (r.step > after)]
    return int((np.hypot(r.x - center[0], r.y - center[1]) < radius).sum())


@pytest.mark.slow
def test_after_inference_teammates_enter_the_jamming_region_less():
    """Seeds where robot 0 loses its radio early: from then on its teammates spend less time
    in the jammer's attack region than a team that neither suspects nor infers the zone."""
    radius = 2 * np.sqrt(0.05)  # the region where this zone attacks: its disk hazard
    totals = np.zeros(2)
    for seed in (1, 2, 3, 5):
        with_inference = run_episode(circling_scenario(infer=True), seed=seed)
        without = run_episode(circling_scenario(infer=False), seed=seed)
        assert not (without["events"].event == "zone_inferred").any()
        assert (with_inference["events"].event == "zone_inferred").any()
        hit = with_inference["events"].query("event == 'attack' and robot == 0").step.min()
        center = with_inference["zones"][["true_x", "true_y"]].to_numpy()[0]
        near = [_time_near(r, [1, 2], center, radius, hit) for r in (with_inference, without)]
        assert near[0] <= near[1], (seed, near)
        totals += near
    assert totals[1] >= 100
    assert totals[0] <= 0.75 * totals[1], totals


# ---------------------------------------------------------------------------- comm, temporary


def test_temporary_comm_failure_plans_alone_recovers_rejoins_and_merges():
    s = scenario(
        steps=150,
        robots=[{"start": [0.0, 0.0]}, {"start": [-2.0, 1.0]}, {"start": [-2.0, -1.0]}],
        targets=[{"start": [-1.0, 0.0], "motion": STILL}],
        zones=[disk_comm_zone([0.0, 0.0], "temporary")],
        # robot 0 lingers on the jammer, 1 m from the target, as the one-step program lets it
        # (the route program would head for the target before the first activation tick)
        planner={"program": "one_step"},
    )
    result = run_episode(s, seed=1)
    events, robots, knowledge = result["events"], result["robots"], result["knowledge"]
    hit = events[(events.event == "attack") & (events.robot == 0)].iloc[0]
    k0 = int(hit.step)
    rec = events[(events.event == "recover") & (events.robot == 0)]
    assert len(rec), "the isolated robot must escape the zone and recover"
    k1 = int(rec.step.iloc[0])
    r0 = robots[robots.robot == 0].set_index("step")
    assert set(r0.loc[k0 : k1 - 1, "mode"]) == {"individual"}
    merges = events[(events.event == "league_merge") & (events.step >= k1)]
    assert len(merges) and "lambda=" in merges.detail.iloc[0]
    # what it learned while isolated reaches the others once it is back
    shared = knowledge[(knowledge.zone == 0) & knowledge.robot.isin([1, 2])]
    assert set(shared.robot) == {1, 2}
    assert shared.step.min() >= k1
    assert set(shared.source) == {"broadcast"}


# ---------------------------------------------------------------------------- structure


def test_two_leagues_plan_jointly_and_independently():
    s = scenario(
        steps=40,
        comm_range=2.0,
        # the one-step program keeps the two leagues apart; under the route program each
        # league, not knowing the other covers the far target, sends a robot to it and the
        # leagues merge
        planner={"program": "one_step"},
        robots=[
            {"start": [-3.0, 0.5]},
            {"start": [-3.0, -0.5]},
            {"start": [3.0, 0.5]},
            {"start": [3.0, -0.5]},
        ],
        targets=[
            {"start": [-1.5, 0.0], "motion": STILL},
            {"start": [1.5, 0.0], "motion": STILL},
        ],
    )
    result = run_episode(s, seed=1)
    team, robots = result["team"], result["robots"]
    assert (team.n_leagues == 2).all()
    assert (team.n_solves == 2).all()
    assert set(robots["mode"]) == {"league"}
    leagues = robots.groupby("robot").league.unique()
    assert {tuple(v) for v in leagues} == {(0,), (1,)}
    # each league moves toward the target on its side
    last = robots[robots.step == robots.step.max()].set_index("robot")
    assert (last.loc[[0, 1], "x"] > -3.0).all() and (last.loc[[2, 3], "x"] < 3.0).all()


@pytest.mark.slow
@pytest.mark.parametrize("name", ["combined-temp", "combined-perm"])
def test_combined_zones_are_learned_progressively(name):
    result = run_episode(shipped(name), policy="failure_aware", seed=1)
    knowledge = result["knowledge"]
    first = knowledge.groupby("zone").step.min().sort_values()
    assert len(first) >= 2
    assert first.is_monotonic_increasing and first.iloc[0] < first.iloc[-1]
    assert first.iloc[0] > 0  # nothing is known at the start


def test_zone_rows_follow_the_known_zones_w5_and_being_alone():
    """The rows are reused only while nothing they depend on changed; each call gets copies."""
    from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate

    def zone(key: str, kind: str, x: float) -> ZoneEstimate:
        return ZoneEstimate(
            key, kind, np.array([x, 0.0]), 0.1 * np.eye(2), 0.4, "permanent", "attack", 1
        )

    s = scenario()
    exposure = GuardsSpec.model_validate({"exposure": {"enabled": True}})
    policy = FailureAwarePolicy(
        team_config(s), s.policy.params_for("failure_aware"), None, exposure
    )
    fresh = FailureAwarePolicy(team_config(s), s.policy.params_for("failure_aware"), None, exposure)
    knowledge = KnowledgeBase()
    knowledge.learn(zone("zone0", "sensing", 1.0))
    knowledge.learn(zone("zone1", "comm", 2.0))
    calls = [(0.1, False, 0.02), (0.1, False, 0.02), (0.2, False, 0.02), (0.2, True, 0.02)]
    calls += [(0.2, True, 0.01)]
    for w5, alone, eps in calls:
        rows = policy._zone_rows(knowledge, w5, alone, eps)
        expected = fresh._make_zone_rows(knowledge, w5, alone, eps)
        for got, want in zip(rows, expected, strict=True):
            np.testing.assert_array_equal(got, want)
        rows[0][:] = -1.0  # a caller's change must not reach the next call
    for p in (policy, fresh):
        ledger = next(g for g in p.guards if isinstance(g, ExposureGuard)).ledger
        ledger.steps["zone0"] = 1000
    rows = policy._zone_rows(knowledge, 0.2, True, 0.01)  # exposure changed: new rows
    np.testing.assert_array_equal(rows[0], fresh._make_zone_rows(knowledge, 0.2, True, 0.01)[0])
    knowledge.learn(zone("zone2", "sensing", 3.0))
    sensing, comm, keys, n_sensing, _ = policy._zone_rows(knowledge, 0.2, True, 0.02)
    assert len(sensing) == 3 and len(comm) == 0  # alone: the comm zone becomes a disc
    assert (keys, n_sensing) == (["zone0", "zone2", "zone1"], 2)
    sensing, comm, _, _, _ = policy._zone_rows(knowledge, 0.2, False, 0.02)
    assert (len(sensing), len(comm)) == (3, 1)  # a league: the disc (hazard) and eq. 7d
    knowledge.learn(
        ZoneEstimate(
            "zone3", "comm", np.array([6.0, 0.0]), 0.1 * np.eye(2), 0.4, "temporary", "attack", 1
        )
    )
    sensing, comm, _, _, _ = policy._zone_rows(knowledge, 0.2, False, 0.02)
    assert (len(sensing), len(comm)) == (3, 2)  # a temporary one: eq. 7d only


@pytest.mark.parametrize("guard", [True, False])
def test_a_league_guards_known_temporary_jammers_only_when_asked(guard):
    """Without the ``ignore_temporary_jammers`` guard (the default: the paper's eq. 7d for every
    known comm zone) every comm zone keeps its eq. 7d rows; with it only those known to be
    temporary are dropped, and only for leagues."""
    from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate

    def comm(key: str, persistence: str, x: float) -> ZoneEstimate:
        return ZoneEstimate(
            key, "comm", np.array([x, 0.0]), 0.1 * np.eye(2), 0.2, persistence, "attack", 1
        )

    s = scenario()
    params = s.policy.params_for("failure_aware")
    guards = GuardsSpec.model_validate({"ignore_temporary_jammers": {"enabled": not guard}})
    policy = FailureAwarePolicy(team_config(s), params, None, guards)
    knowledge = KnowledgeBase()
    for key, persistence, x in [
        ("a", "temporary", 1.0),
        ("b", "permanent", 5.0),  # far apart: three zones, not one (Mahalanobis)
        ("c", "unknown", 9.0),
    ]:
        knowledge.learn(comm(key, persistence, x))
    _, league_rows, _, _, _ = policy._make_zone_rows(knowledge, 0.0, False, params.eps1)
    kept = {float(row[0]) for row in league_rows}  # each row starts with the zone's x
    assert kept == ({1.0, 5.0, 9.0} if guard else {5.0, 9.0})
    discs, _, _, _, _ = policy._make_zone_rows(knowledge, 0.0, True, params.eps1)
    assert len(discs) == 3  # a robot alone keeps clear of every known comm zone either way


@pytest.mark.parametrize("guard", [True, False])
def test_the_hazard_guard_keeps_a_league_off_known_comm_zones_and_spares_the_last_sensors(guard):
    """With the ``comm_hazard`` guard a league gets an eq. 7c disc around each known comm zone
    besides eq. 7d, and with ``last_sensors`` β1 grows as sensors are lost; without them, the
    paper's constraint set."""
    from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate

    s = scenario()
    params = s.policy.params_for("failure_aware")
    guards = GuardsSpec.model_validate({g: {"enabled": guard} for g in PAPER_OFF})
    policy = FailureAwarePolicy(team_config(s), params, None, guards)
    knowledge = KnowledgeBase()
    knowledge.learn(
        ZoneEstimate(
            "c", "comm", np.array([2.0, 0.0]), 0.1 * np.eye(2), 0.2, "permanent", "attack", 1
        )
    )
    discs, jam_rows, _, _, _ = policy._make_zone_rows(knowledge, 0.3, False, params.eps1)
    assert len(jam_rows) == 1
    if guard:
        assert len(discs) == 1
        assert discs[0][5] == pytest.approx(params.comm_clearance + 0.3)  # r_safe: + w5
        assert discs[0][6] == pytest.approx(policy.beta1)  # at the sensing zones' risk level
    else:
        assert len(discs) == 0
    risks = [policy._sensing_risk(s_, 3) for s_ in (3, 2, 1, 0)]
    assert risks[0] == params.eps1
    if guard:
        assert risks[0] > risks[1] > risks[2] == risks[3]
    else:
        assert risks == [params.eps1] * 4


def test_a_circling_robot_turns_back_at_a_known_sensing_zone():
    """With the ``safe_circling`` guard a robot circling its comm attacker (Alg. 4) that still
    senses does not fly its circle into a known sensing zone's keep-out disc: it turns back."""
    from resilient_tracking.belief.knowledge import KnowledgeBase, ZoneEstimate
    from resilient_tracking.policies.guards.safe_circling import enters as _enters

    s = scenario()
    policy = FailureAwarePolicy(team_config(s), s.policy.params_for("failure_aware"))
    knowledge = KnowledgeBase()
    sensing = ZoneEstimate(
        "s", "sensing", np.array([1.5, 0.0]), 0.05 * np.eye(2), 0.3, "permanent", "attack", 1
    )
    knowledge.learn(sensing)
    rows = policy._make_zone_rows(knowledge, 0.0, True, policy.params.eps1)[0]
    # heading straight into the disc enters it; leaving it, or staying far, does not
    assert _enters(np.array([0.75, 0.0]), np.array([0.1, 0.0]), rows)
    assert not _enters(np.array([0.6, 0.0]), np.array([0.05, 0.0]), rows)  # stays outside
    assert not _enters(np.array([0.85, 0.0]), np.array([-0.1, 0.0]), rows)  # leaves it
    assert not _enters(np.array([-2.0, 0.0]), np.array([0.1, 0.0]), rows)


def test_exposure_halves_a_zones_risk_level_each_time_it_doubles():
    """Robot-steps near a keep-out disc are counted (far ones are not); the zone's risk level
    halves at ``H``, ``3H``, ``7H`` steps, so its β grows in steps, and a horizon of 0 never
    changes it."""
    from resilient_tracking.planning.adaptation import chance_margin
    from resilient_tracking.planning.layout import sensing_row, sensing_table
    from resilient_tracking.policies.guards.exposure import ExposureLedger

    ledger = ExposureLedger(horizon=10)
    rows = sensing_table([sensing_row([0.0, 0.0], 0.1 * np.eye(2), r_safe=0.5, beta=1.0)])
    near, far = np.array([[0.9, 0.0]]), np.array([[3.0, 0.0]])
    levels = []
    for _ in range(70):
        ledger.record(["z"], rows, np.vstack([near, far]))
        levels.append(ledger.level("z"))
    assert ledger.steps == {"z": 70}  # the far robot adds nothing
    assert [levels.index(k) + 1 for k in (1, 2, 3)] == [10, 30, 70]
    assert chance_margin(ledger.risk(0.02, "z")) == pytest.approx(chance_margin(0.02 / 8))
    off = ExposureLedger(horizon=0)
    off.record(["z"], rows, near)
    assert off.level("z") == 0 and off.risk(0.02, "z") == 0.02
