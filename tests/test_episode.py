"""End-to-end behaviour of episodes: determinism, records, the vanilla team's failure mode."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from helpers import shipped
from resilient_tracking.runs.records import ColumnTable, write_run
from resilient_tracking.runs.schema import REPRODUCIBLE
from resilient_tracking.scenario.overrides import every_zone_known
from resilient_tracking.sim.episode import run_episode


def test_same_seed_same_tables_different_seed_different_draws(tmp_path):
    scenario = shipped("sensing-temp").with_overrides(steps=60)
    a = run_episode(scenario, seed=3)
    b = run_episode(scenario, seed=3)
    c = run_episode(scenario, seed=4)
    for name in REPRODUCIBLE:
        pd.testing.assert_frame_equal(a[name], b[name])
    assert not np.allclose(a["zones"]["true_x"], c["zones"]["true_x"])
    # written files read back identical too
    write_run(a, tmp_path / "a")
    write_run(b, tmp_path / "b")
    for name in REPRODUCIBLE:
        pd.testing.assert_frame_equal(
            pd.read_parquet(tmp_path / "a" / f"{name}.parquet"),
            pd.read_parquet(tmp_path / "b" / f"{name}.parquet"),
        )


def test_known_zones_are_held_from_step_0_as_their_priors_never_their_true_centres():
    scenario = every_zone_known(shipped("combined-temp").with_overrides(steps=3))
    result = run_episode(scenario, policy="failure_aware", seed=5)
    first = result["knowledge"][result["knowledge"]["step"] == 0]
    assert sorted(zip(first.robot, first.zone, strict=True)) == [
        (robot, zone) for robot in range(3) for zone in range(3)
    ]
    assert set(first.source) == {"broadcast"}
    zones = result["zones"].set_index("zone")
    for row in first.itertuples():
        spec = scenario.zones[row.zone]
        assert (row.x, row.y) == tuple(spec.mu) and row.size == spec.size
        assert (row.x, row.y) != (zones.true_x[row.zone], zones.true_y[row.zone])
    learned = result["events"][result["events"]["event"] == "zone_learned"]
    assert len(learned) == 9 and set(learned.step) == {0}
    vanilla = run_episode(scenario, policy="vanilla", seed=5)
    assert vanilla["knowledge"].empty  # a team without zone knowledge ignores the map


def test_a_team_that_knows_the_zone_from_the_start_is_attacked_less():
    """It keeps clear of the zone from step 0 instead of learning it by being attacked; with
    ``known: false`` written out the run is the default one, bit for bit."""
    scenario = shipped("sensing-temp").with_overrides(steps=150)
    attacks = {}
    for seed in (1, 2, 3):
        learned = run_episode(scenario, seed=seed)
        known = run_episode(every_zone_known(scenario), seed=seed)
        attacks[seed] = (
            (learned["robots"]["sensing_ok"] == 0).sum(),
            (known["robots"]["sensing_ok"] == 0).sum(),
        )
    assert sum(k for _, k in attacks.values()) < sum(lr for lr, _ in attacks.values()), attacks
    written = scenario.with_overrides(
        zones=[z.model_dump() | {"known": False} for z in scenario.zones]
    )
    again = run_episode(written, seed=3)
    for name in REPRODUCIBLE:
        pd.testing.assert_frame_equal(again[name], learned[name])


def test_records_have_the_documented_shape():
    scenario = shipped("comm-temp").with_overrides(steps=40)
    result = run_episode(scenario, seed=1)
    team, robots, targets = result["team"], result["robots"], result["targets"]
    assert list(team["step"]) == list(range(40))
    for column in (
        "step",
        "time",
        "mse",
        "trace",
        "effort",
        "n_sensing_failed",
        "n_comm_failed",
        "n_leagues",
    ):
        assert column in team.columns
    assert len(robots) == 40 * 3 and len(targets) == 40 * 3
    for column in (
        "step",
        "robot",
        "x",
        "y",
        "ux",
        "uy",
        "sensing_ok",
        "comm_ok",
        "league",
        "mode",
    ):
        assert column in robots.columns
    assert np.isfinite(team[["mse", "trace", "effort"]].to_numpy()).all()
    # applied velocities respect the bounds, positions follow x+ = x + u dt
    assert (robots[["ux", "uy"]].abs() <= 1.0 + 1e-9).all().all()
    r0 = robots[robots.robot == 0].sort_values("step")
    np.testing.assert_allclose(
        r0["x"].to_numpy()[1:], r0["x"].to_numpy()[:-1] + 0.1 * r0["ux"].to_numpy()[:-1]
    )
    # effort is Σ‖u‖ of the applied velocities
    per_step = robots.assign(n=np.hypot(robots.ux, robots.uy)).groupby("step")["n"].sum()
    np.testing.assert_allclose(team.set_index("step")["effort"], per_step)


@pytest.mark.parametrize("seed", [1, 2])
def test_vanilla_in_sensing_perm_every_robot_attacked_then_trace_explodes(seed):
    """docs/model.md §8 / paper Fig. 4: the vanilla team is immobilised and its trace explodes."""
    result = run_episode(shipped("sensing-perm"), policy="vanilla", seed=seed)
    events, team, robots = result["events"], result["team"], result["robots"]
    attacks = events[events.event == "attack"]
    assert sorted(attacks.robot.unique()) == [0, 1, 2]
    last = int(attacks.step.max())
    after = team[team.step >= last]["trace"].to_numpy()
    assert after[-1] > 100 * after[0]
    assert np.all(np.diff(after[5:]) > 0)  # keeps rising
    still = robots[robots.step > last]
    assert (still[["ux", "uy"]].abs().max() < 1e-9).all()  # immobilised
    assert set(still["mode"]) == {"idle"}


def test_column_tables_grow_in_blocks_and_keep_dtypes():
    table = ColumnTable({"step": np.int64, "x": np.float64, "ok": np.bool_, "mode": object})
    for k in range(40):  # past the initial capacity, several doublings
        modes = np.empty(3, dtype=object)
        modes[:] = ["track", "evade", "track"]
        table.append(
            step=k, x=np.arange(3) + 0.5 * k, ok=np.array([True, False, k % 2 == 0]), mode=modes
        )
    frame = table.frame()
    assert len(table) == len(frame) == 120
    assert frame["step"].tolist() == [k for k in range(40) for _ in range(3)]
    assert frame["x"].iloc[-1] == 2 + 0.5 * 39
    assert frame["ok"].dtype == bool and frame["ok"].tolist()[-3:] == [True, False, False]
    assert frame["mode"].tolist()[:3] == ["track", "evade", "track"]


def test_single_rows_append_like_blocks_of_one():
    dtypes = {"step": np.int64, "x": np.float64, "n": np.int64}
    by_row, by_block = ColumnTable(dtypes, capacity=2), ColumnTable(dtypes, capacity=2)
    for k in range(9):  # past the capacity: the row path grows the columns too
        values = {"step": k, "x": np.float64(0.1) * k, "n": np.int64(k % 3)}
        by_row.append_row(**values)
        by_block.append(1, **values)
    assert len(by_row) == 9
    pd.testing.assert_frame_equal(by_row.frame(), by_block.frame())


@pytest.mark.parametrize(
    ("solver", "first_rungs"), [("ladder", {"sqp"}), ("ipopt", {"cold", "warm"})]
)
def test_the_scenarios_planner_solver_is_used(solver, first_rungs):
    seen: list[str] = []

    def record(rung, solution, stats):
        seen.append(rung)
        return solution, stats

    scenario = shipped("sensing-temp").with_overrides(steps=5, planner={"solver": solver})
    run_episode(scenario, seed=1, fault_hook=record)
    assert seen and set(seen) <= first_rungs, seen
