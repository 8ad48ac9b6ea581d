"""``rtrack compare``: overrides, confidence intervals, paired wins, a resumable report."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from helpers import shipped
from resilient_tracking.cli import main
from resilient_tracking.experiments.comparison import (
    apply_overrides,
    confidence_interval,
    make_study,
    parse_override,
    summary_table,
    wins,
)
from resilient_tracking.scenario import ScenarioError


def test_override_values_are_read_as_yaml():
    assert parse_override("policy.failure_aware.eps1=0.05") == ("policy.failure_aware.eps1", 0.05)
    assert parse_override("zones.0.mu=[1, 2]") == ("zones.0.mu", [1, 2])
    with pytest.raises(ValueError, match="--set"):
        parse_override("steps")


def test_overrides_reach_the_scenario_and_bad_ones_name_the_field():
    scenario = shipped("sensing-temp")
    changed = apply_overrides(scenario, [("policy.failure_aware.eps1", 0.05), ("steps", 20)])
    assert changed.policy.failure_aware.eps1 == 0.05
    assert changed.steps == 20
    with pytest.raises(ScenarioError, match="policy.failure_aware.eps1"):
        apply_overrides(scenario, [("policy.failure_aware.eps1", 0.9)])
    with pytest.raises(ScenarioError, match="zones.7.mu"):
        apply_overrides(scenario, [("zones.7.mu", [0, 0])])


def test_confidence_interval_is_students_t():
    values = np.array([1.0, 2.0, 4.0, 7.0])
    low, high = confidence_interval(values)
    half = stats.t.ppf(0.975, 3) * values.std(ddof=1) / 2
    assert (low, high) == pytest.approx((values.mean() - half, values.mean() + half))
    assert all(np.isnan(confidence_interval(np.array([3.0]))))


@pytest.mark.slow
def test_paired_wins_and_best_counts_compare_seed_by_seed():
    runs = pd.DataFrame(
        {
            "scenario": "s",
            "policy": ["a", "b", "a", "b", "a", "b"],
            "seed": [1, 1, 2, 2, 3, 3],
            "trace": [1.0, 2.0, 3.0, 1.0, 1.0, 5.0],
            "mse": 0.0,
            "effort": 0.0,
            "sensing_attacks": 0,
            "comm_attacks": 0,
            "survival_steps": [10, 20, 10, 20, 10, 20],
        }
    )
    w = wins(runs, "trace")
    assert (w.loc["a", "b"], w.loc["b", "a"]) == (2, 1)
    table = summary_table(runs).set_index(["policy", "metric"])
    assert table.loc[("a", "trace"), "best_in"] == 2
    assert table.loc[("b", "survival_steps"), "best_in"] == 3  # higher is better
    assert table.loc[("a", "mse"), "best_in"] == 0  # ties are no wins


def test_unknown_policy_and_scenario_fail_before_running():
    with pytest.raises(ValueError, match="--policies"):
        make_study(["sensing-temp"], ["vanila"], 2)
    with pytest.raises(ScenarioError, match="shipped scenario"):
        make_study(["no-such-scenario"], ["vanilla"], 2)


@pytest.mark.slow
def test_compare_writes_a_report_and_resumes(tmp_path, capsys):
    out = tmp_path / "C"
    argv = [
        "compare",
        "sensing-temp",
        "--policies",
        "failure_aware,vanilla",
        "--seeds",
        "2",
        "--set",
        "steps=15",
        "--out",
        str(out),
        "--jobs",
        "1",
        "-q",
    ]
    assert main(argv) == 0
    assert "4 run(s) done" in capsys.readouterr().out
    report = (out / "report.md").read_text()
    assert "## sensing-temp" in report and "`steps=15`" in report
    assert "| failure_aware | 2 |" in report and "| vanilla | 2 |" in report
    for name in ("bands", "boxes", "snapshots-failure_aware", "snapshots-vanilla"):
        assert (out / "sensing-temp" / "figures" / f"{name}.png").stat().st_size > 0
    runs = pd.read_csv(out / "runs.csv")
    assert sorted(zip(runs.policy, runs.seed, strict=True)) == [
        ("failure_aware", 1),
        ("failure_aware", 2),
        ("vanilla", 1),
        ("vanilla", 2),
    ]
    assert main(argv) == 0
    assert "0 run(s) done, 4 already stored" in capsys.readouterr().out


def test_compare_reports_a_bad_override_without_a_traceback(tmp_path, capsys):
    code = main(["compare", "sensing-temp", "--set", "dt=-1", "--out", str(tmp_path / "x")])
    assert code == 1
    assert "dt:" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_dask_logs_are_quiet_without_verbose(tmp_path, capfd):
    argv = ["compare", "sensing-temp", "--seeds", "1", "--policies", "vanilla", "--set"]
    argv += ["steps=5", "--dask", "local", "--jobs", "1", "--out", str(tmp_path / "d"), "-q"]
    assert main(argv) == 0
    err = capfd.readouterr().err
    assert "INFO" not in err, err
