"""The beyond benchmark: generated zone features, the stored beyond suite, and the ``beyond``
experiment's arms, targets and figures."""

from __future__ import annotations

from collections import Counter

import numpy as np
import pandas as pd
import pytest

from resilient_tracking.cli import main
from resilient_tracking.experiments.beyond_features import (
    COMM_RANGE,
    MOTION_KINDS,
    moving_exposure,
    zone_path,
)
from resilient_tracking.experiments.catalog import (
    BEYOND,
    BEYOND_SUITE_SEEDS,
    SUITE_SIZE,
    catalog,
    tasks,
)
from resilient_tracking.experiments.claims import BEYOND_SUITE_TARGETS, check
from resilient_tracking.experiments.generator import (
    DT,
    STEPS,
    SUITE_SEED,
    WORKSPACE,
    exposure,
    stored_beyond_suite,
    stored_suite,
    suite,
)
from resilient_tracking.scenario import Scenario, load_scenario
from resilient_tracking.scenario.teams import get_team


@pytest.fixture(scope="module")
def beyond_suite() -> list[Scenario]:
    return stored_beyond_suite()


def features(scenario: Scenario) -> set[str]:
    """The features beyond the paper a scenario's zones have."""
    out = set()
    for zone in scenario.zones:
        if zone.motion is not None:
            out.add(f"moving {zone.motion.type}")
        if len(zone.kinds) == 2:
            out.add("multimodal")
        if zone.effect.type == "degrade":
            announced = "announced" if zone.effect.announced else "silent"
            out.add(f"degrade {zone.kinds[0]} {announced}")
        if getattr(zone, "spread", None) is not None:
            out.add("spread")
    return out


def test_the_stored_beyond_suite_is_what_the_generator_draws():
    # as for the plain suite: `python tools/generate_suite.py --beyond` writes it again
    head = [s.model_dump() for s in suite(SUITE_SEED, 2, beyond=True)]
    assert head == [s.model_dump() for s in stored_beyond_suite(2)]


def test_a_beyond_scenario_is_the_plain_one_with_zone_features(beyond_suite):
    """Own stream: robots, targets and the zones' names, spreads and persistences are those of
    the plain suite's scenario of the same index; a zone that does not move keeps its centre."""
    plain = stored_suite(SUITE_SIZE)
    assert len(beyond_suite) == len(plain) == SUITE_SIZE >= 60
    for ours, theirs in zip(beyond_suite, plain, strict=True):
        assert ours.name == theirs.name
        assert ours.robots == theirs.robots and ours.targets == theirs.targets
        assert [z.name for z in ours.zones] == [z.name for z in theirs.zones]
        for zone, base in zip(ours.zones, theirs.zones, strict=True):
            assert zone.sigma == base.sigma and zone.persistence == base.persistence
            if zone.motion is None:
                assert zone.mu == base.mu
            assert set(base.kinds) <= set(zone.kinds)


def test_every_beyond_scenario_has_a_feature_and_the_suite_covers_them_all(beyond_suite):
    counts = Counter(f for s in beyond_suite for f in features(s))
    assert all(features(s) for s in beyond_suite)
    expected = {f"moving {kind}" for kind in MOTION_KINDS} | {"multimodal", "spread"}
    expected |= {f"degrade {k} {a}" for k in ("sensing", "comm") for a in ("announced", "silent")}
    assert set(counts) == expected, counts


def test_spreading_zones_are_permanent_comm_zones_in_a_scenario_with_a_radio_range(beyond_suite):
    spreading = [s for s in beyond_suite if "spread" in features(s)]
    assert spreading
    for s in beyond_suite:
        if "spread" in features(s):
            assert s.comm_range is not None and COMM_RANGE[0] <= s.comm_range <= COMM_RANGE[1]
            for zone in s.zones:
                if getattr(zone, "spread", None) is not None:
                    assert zone.kinds == ("comm",) and zone.persistence == "permanent"
                    assert zone.effect.type == "fail"
        else:
            assert s.comm_range is None


def test_moving_zones_stay_in_the_workspace(beyond_suite):
    moving = [z for s in beyond_suite for z in s.zones if z.motion is not None]
    assert len(moving) >= 10
    for zone in moving:
        path = zone_path(np.array(zone.mu), zone.motion.model_dump(), STEPS, DT)
        assert (path[:, 0] >= WORKSPACE["xmin"]).all() and (path[:, 0] <= WORKSPACE["xmax"]).all()
        assert (path[:, 1] >= WORKSPACE["ymin"]).all() and (path[:, 1] <= WORKSPACE["ymax"]).all()


def test_a_still_zone_is_met_as_the_generator_measures_a_static_one():
    rng = np.random.default_rng(3)
    robot_paths = rng.uniform(-2, 2, (STEPS, 4, 2))
    zone = {
        "mu": [0.3, -0.2],
        "sigma": [[0.2, 0.05], [0.05, 0.15]],
        "hazard": {"kappa": 0.7, "f_act": 1.0},
    }
    still = np.tile(np.array(zone["mu"]), (STEPS, 1))
    assert moving_exposure(zone, still, robot_paths, DT) == pytest.approx(
        exposure(zone, robot_paths), rel=1e-12
    )
    away = still + 5.0  # a zone that moved far from the robots is not met
    assert moving_exposure(zone, away, robot_paths, DT) < 1e-3 * exposure(zone, robot_paths)


def test_rtrack_generate_beyond_writes_the_stored_beyond_suite(tmp_path, capsys):
    out = tmp_path / "beyond"
    assert main(["generate", "-n", "2", "--beyond", "--out", str(out), "-q"]) == 0
    written = [load_scenario(out / f"g{i:02d}.yaml") for i in range(2)]
    assert [s.model_dump() for s in written] == [s.model_dump() for s in stored_beyond_suite(2)]
    assert "--beyond" in (out / "g00.yaml").read_text().splitlines()[0]


def test_generate_help_documents_beyond(capsys):
    with pytest.raises(SystemExit):
        main(["generate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--beyond" in text and "multimodal" in text and "spreading" in text


def test_beyond_experiment_runs_three_teams_on_the_shipped_scenarios_and_the_suite():
    exp = catalog()["beyond"]
    assert exp.seeds == 10
    cases = exp.generated()
    names = [s.name for s, _ in cases]
    assert names[: len(BEYOND)] == list(BEYOND)
    assert names[len(BEYOND) :] == [s.name for s in stored_beyond_suite()]
    every = tasks(exp)
    for _, variants in cases:
        teams = {v.tags["team"]: v for v in variants}
        assert set(teams) == {"vanilla", "default", "beyond"}
        assert teams["vanilla"].policy == "vanilla"
        assert {t: v.overrides for t, v in teams.items()} == {t: {"team": t} for t in teams}
        assert set(get_team("default").settings.items()) < set(get_team("beyond").settings.items())
        arm = next(t for t in every if t.variant == teams["beyond"])
        assert {"quarantine", "signal_turns"} <= set(arm.scenario.guards.enabled())
        belief = arm.scenario.belief
        assert belief.degradation_watch.enabled and belief.zone_motion.enabled
        paper = next(t for t in every if t.variant == teams["default"])
        assert "quarantine" not in paper.scenario.guards.enabled()
    seeds = Counter(t.variant.tags["part"] for t in every)
    assert seeds == {"shipped": len(BEYOND) * 3 * 10, "suite": SUITE_SIZE * 3 * BEYOND_SUITE_SEEDS}
    quick = tasks(catalog(quick=True)["beyond"])
    assert len(quick) < len(every) / 5
    assert {t.variant.tags["part"] for t in quick} == {"shipped", "suite"}


def _rows(scenario: str, part: str, mse: list[float], nll: list[float]) -> pd.DataFrame:
    """Two seeds of the three teams on ``scenario`` (vanilla, default, beyond per seed)."""
    return pd.DataFrame(
        {
            "tag_scenario": scenario,
            "tag_part": part,
            "tag_team": ["vanilla", "default", "beyond"] * 2,
            "seed": [1, 1, 1, 2, 2, 2],
            "mse": mse,
            "nll": nll,
        }
    )


def test_beyond_targets_are_won_tied_or_lost_by_the_paired_interval():
    exp = catalog()["beyond"]
    shipped = _rows(
        "comm-spread",
        "shipped",
        # beyond 1 below default in both seeds (won); against vanilla −1 then +1 (tied)
        mse=[2.0, 3.0, 2.0, 1.0, 3.0, 2.0],
        # beyond 0.5 above vanilla in both seeds (lost); below default (won)
        nll=[1.0, 2.0, 1.5, 1.0, 2.0, 1.5],
    )
    suite_rows = pd.concat(
        [
            # g00: beyond above default in both seeds (lost), below vanilla (won)
            _rows("g00", "suite", [3, 1, 2, 3, 1, 2], [1] * 6),
            # g01: beyond against default +1 then −1 (tied), below vanilla (won)
            _rows("g01", "suite", [3, 1, 2, 3, 3, 2], [1] * 6),
        ]
    )
    claims = check(exp, pd.concat([shipped, suite_rows], ignore_index=True))
    verdict = {c.statement: ("tie" if c.tie else c.holds) for c in claims}
    paper, vanilla = BEYOND_SUITE_TARGETS["default"], BEYOND_SUITE_TARGETS["vanilla"]
    assert verdict == {
        "comm-spread: the beyond team has a lower MSE than the default team": True,
        "comm-spread: the beyond team has a lower NLL than the default team": True,
        "comm-spread: the beyond team has a lower MSE than vanilla": "tie",
        "comm-spread: the beyond team has a lower NLL than vanilla": False,
        "beyond suite: the beyond team loses to the default team in MSE in at most "
        f"{paper:.0%} of the scenarios (ties apart)": False,  # 1 of 2 lost
        "beyond suite: the beyond team loses to the default team in NLL in at most "
        f"{paper:.0%} of the scenarios (ties apart)": True,  # equal: tied
        "beyond suite: the beyond team loses to vanilla in MSE in at most "
        f"{vanilla:.0%} of the scenarios (ties apart)": True,  # 2 of 2 won
        "beyond suite: the beyond team loses to vanilla in NLL in at most "
        f"{vanilla:.0%} of the scenarios (ties apart)": True,
    }
    evidence = {c.statement: c.evidence for c in claims}
    default_mse = next(e for k, e in evidence.items() if "default team in MSE" in k)
    assert default_mse.startswith("0 won, 1 tied, 1 lost of 2")
    vanilla_mse = next(e for k, e in evidence.items() if "vanilla in MSE" in k)
    assert vanilla_mse.startswith("2 won, 0 tied, 0 lost of 2") and "[-1, -1]" in vanilla_mse


def test_beyond_team_consistency_is_claimed_where_a_sensing_zone_degrades():
    exp = catalog()["beyond"]
    rows = _rows("sensing-degrade", "shipped", [2.0, 2.0, 1.0] * 2, [3.0, 3.0, 1.0] * 2)
    rows = rows.assign(tag_degrades=True, steps=300, targets=3, anees=[80.0, 80.0, 2.01] * 2)
    claims = [c for c in check(exp, rows) if "consistent" in c.statement]
    assert [c.holds for c in claims] == [True]
    far = check(exp, rows.assign(anees=[80.0, 80.0, 3.0] * 2))
    assert [c.holds for c in far if "consistent" in c.statement] == [False]
    assert not [
        c for c in check(exp, rows.drop(columns="tag_degrades")) if "consistent" in c.statement
    ]


def test_beyond_figures_are_bands_and_snapshots_of_the_shipped_scenarios_only(tmp_path):
    from resilient_tracking.experiments.report_figures import figure_jobs

    exp = catalog()["beyond"]
    labels = [v.label for _, variants in exp.generated() for v in variants]
    jobs = figure_jobs(exp, {label: [] for label in labels}, pd.DataFrame(), tmp_path)
    bands = {job.path.name: job for job in jobs if job.path.name.startswith("bands-")}
    assert set(bands) == {f"bands-{name}.png" for name in BEYOND}
    teams = bands["bands-comm-spread.png"].args[0]
    assert set(teams) == {"comm-spread-vanilla", "comm-spread-default", "comm-spread-beyond"}


def test_feature_counts_name_each_shipped_scenarios_feature():
    from resilient_tracking.builtin_scenarios import load
    from resilient_tracking.experiments.beyond_features import feature_counts

    counts = feature_counts(load(name) for name in BEYOND)
    assert counts["scenarios"] == 6 and counts["zones"] == 6
    assert counts["moving (waypoints)"] == counts["moving (circle)"] == 1
    assert counts["degrading sensing (silent)"] == counts["degrading comm (announced)"] == 1
    assert counts["spreading"] == counts["multimodal"] == 1
    assert counts["scenarios with a radio range"] == 1
