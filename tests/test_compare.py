"""``rtrack compare``: overrides, confidence intervals, paired wins, a resumable report."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from helpers import SCENARIOS, shipped
from resilient_tracking.cli import main
from resilient_tracking.experiments.comparison import (
    describe_seeds,
    make_study,
    parse_override,
    parse_seeds,
)
from resilient_tracking.experiments.comparison_stats import (
    last_third_ratios,
    paired_differences,
    summary_table,
    wins,
)
from resilient_tracking.experiments.paired import confidence_interval
from resilient_tracking.scenario import ScenarioError
from resilient_tracking.scenario.overrides import overridden


def test_override_values_are_read_as_yaml():
    assert parse_override("policy.failure_aware.eps1=0.05") == ("policy.failure_aware.eps1", 0.05)
    assert parse_override("zones.0.mu=[1, 2]") == ("zones.0.mu", [1, 2])
    # numbers as a scenario file reads them (YAML 1.2), not strings as YAML 1.1 has them
    assert parse_override("robots.0.u_max=1e300") == ("robots.0.u_max", 1e300)
    assert parse_override("estimator.accel_std=5E-1") == ("estimator.accel_std", 0.5)
    with pytest.raises(ValueError, match="--set"):
        parse_override("steps")
    with pytest.raises(ValueError, match="--set zones: not valid YAML"):
        parse_override("zones=[1, 2")
    with pytest.raises(ValueError, match="--set a: duplicate key"):
        parse_override("a={x: 1, x: 2}")  # a duplicate key, refused as in a file


def test_overrides_reach_the_scenario_and_bad_ones_name_the_field():
    scenario = shipped("sensing-temp")
    changed = overridden(scenario, {"policy.failure_aware.eps1": 0.05, "steps": 20})
    assert changed.policy.params_for("failure_aware").eps1 == 0.05
    assert changed.steps == 20
    with pytest.raises(ScenarioError, match="policy.failure_aware.eps1"):
        overridden(scenario, {"policy.failure_aware.eps1": 0.9})
    with pytest.raises(ScenarioError, match="zones.7.mu"):
        overridden(scenario, {"zones.7.mu": [0, 0]})


def test_seeds_are_a_count_a_range_or_a_list():
    assert parse_seeds("3", 1000) == (1, 2, 3)
    assert parse_seeds("101-104", 1000) == (101, 102, 103, 104)
    assert parse_seeds("7, 2,7", 1000) == (7, 2)
    assert describe_seeds((101, 102, 103)) == "101..103"
    assert describe_seeds((7, 2)) == "7, 2"
    for text, message in [
        ("0", "between 1 and 1000"),
        ("5000", "between 1 and 1000"),
        ("9-3", "empty range"),
        ("1-2000", "at most 1000 seeds"),
        ("-3,1", "non-negative"),
        ("a-b", "expected N, A-B or a,b,c"),
    ]:
        with pytest.raises(ValueError, match=message):
            parse_seeds(text, 1000)


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
            "nll": [1.0, 2.0, 1.0, 2.0, 1.0, 2.0],
            "anees": [2.1, 5.0, 1.5, 2.2, 2.0, 1.0],  # nearer 2: a, b, a
            "effort": 0.0,
            "sensing_attacks": 0,
            "comm_attacks": 0,
            "robots_attacked": 0,
            "survival_steps": [10, 20, 10, 20, 10, 20],
        }
    )
    w = wins(runs, "trace")
    assert (w.loc["a", "b"], w.loc["b", "a"]) == (2, 1)
    table = summary_table(runs).set_index(["policy", "metric"])
    assert table.loc[("a", "trace"), "best_in"] == 2
    assert table.loc[("b", "survival_steps"), "best_in"] == 3  # higher is better
    assert table.loc[("a", "mse"), "best_in"] == 0  # ties are no wins
    assert table.loc[("a", "nll"), "best_in"] == 3
    assert table.loc[("a", "anees"), "best_in"] == 2  # nearer 2, not lower
    assert wins(runs, "anees").loc["b", "a"] == 1


def test_paired_differences_are_the_mean_and_students_t_interval_of_per_seed_differences():
    runs = pd.DataFrame(
        {
            "policy": ["a"] * 4 + ["b"] * 4,
            "seed": [1, 2, 3, 4] * 2,
            "mse": [1.0, 2.0, 3.0, 4.0, 1.5, 2.0, 4.0, 4.5],
        }
    )
    d = paired_differences(runs, "mse").set_index(["a", "b"])
    diff = np.array([-0.5, 0.0, -1.0, -0.5])
    half = stats.t.ppf(0.975, 3) * diff.std(ddof=1) / 2
    assert d.loc[("a", "b"), "mean"] == pytest.approx(-0.5)
    assert d.loc[("a", "b"), "low"] == pytest.approx(-0.5 - half)
    assert d.loc[("a", "b"), "high"] == pytest.approx(-0.5 + half)
    assert d.loc[("b", "a"), "mean"] == pytest.approx(0.5) and d.loc[("a", "b"), "n"] == 4


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
    assert "| MSE [m²]: row − column, mean [95 % interval] | failure_aware | vanilla |" in report
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


def test_the_zone_free_reference_is_one_run_per_scenario_and_seed_without_zones():
    study = make_study(["sensing-temp", "combined-temp"], ["failure_aware", "vanilla"], [4, 9])
    assert study.zone_free is None and len(study.tasks()) == 8
    study = make_study(
        ["sensing-temp", "combined-temp"], ["failure_aware", "vanilla"], [4, 9], zone_free="vanilla"
    )
    free = [t for t in study.tasks() if t.variant.tags.get("no_zones")]
    assert [(t.experiment, t.seed) for t in free] == [
        ("sensing-temp", 4),
        ("sensing-temp", 9),
        ("combined-temp", 4),
        ("combined-temp", 9),
    ]
    for t in free:
        assert t.variant.label == "vanilla-nozone" and t.variant.policy == "vanilla"
        assert t.scenario.zones == [] and t.scenario.seed == t.seed
        assert t.scenario.robots == study.scenarios[t.experiment].robots
    with pytest.raises(ValueError, match="--zone-free"):
        make_study(["sensing-temp"], ["vanilla"], 1, zone_free="vanila")


def test_last_third_ratios_divide_by_the_reference_run_of_the_same_scenario_and_seed():
    def row(scenario, policy, seed, last_third, free=False):
        return {
            "scenario": scenario,
            "tag_scenario": scenario,
            "policy": policy,
            "seed": seed,
            "last_third_trace": last_third,
            "tag_no_zones": free,
        }

    runs = pd.DataFrame(
        [
            row("b", "failure_aware", 1, 6.0),
            row("b", "vanilla", 1, 30.0),
            row("b", "failure_aware", 2, 4.0),
            row("b", "vanilla", 2, 8.0),
            row("b", "failure_aware", 1, 3.0, free=True),
            row("b", "failure_aware", 2, 4.0, free=True),
            row("a", "failure_aware", 1, 1.0),
            row("a", "vanilla", 1, 2.0),
            row("a", "failure_aware", 1, 0.5, free=True),
        ]
    )
    ratios = last_third_ratios(runs, "failure_aware")
    assert ratios.values.tolist() == [
        ["b", "failure_aware", 1, 2.0],
        ["b", "failure_aware", 2, 1.0],
        ["b", "vanilla", 1, 10.0],
        ["b", "vanilla", 2, 2.0],
        ["a", "failure_aware", 1, 2.0],
        ["a", "vanilla", 1, 4.0],
    ]
    table = summary_table(ratios, [("last_third_ratio", "ratio", True)]).set_index(
        ["scenario", "policy"]
    )
    assert table.loc[("b", "vanilla"), "mean"] == 6.0
    assert table.loc[("b", "failure_aware"), "best_in"] == 2


def test_by_zone_kind_needs_two_policies():
    with pytest.raises(ValueError, match="--by-zone-kind"):
        make_study(["sensing-temp"], ["vanilla"], 1, by_zone_kind=True)


def test_compare_reports_the_zone_free_ratio_and_win_rates_by_zone_kind(tmp_path, capsys):
    out = tmp_path / "Z"
    argv = ["compare", "sensing-temp", "comm-temp", "--seeds", "2-3", "--set", "steps=12"]
    argv += ["--zone-free", "--by-zone-kind", "--out", str(out), "--jobs", "1", "-q"]
    assert main(argv) == 0
    assert "12 run(s) done" in capsys.readouterr().out
    free = out / "runs" / "comm-temp" / "failure_aware-nozone" / "seed-003"
    assert json.loads((free / "manifest.json").read_text())["scenario"]["zones"] == []
    runs = pd.read_csv(out / "runs.csv")
    assert runs.groupby("tag_no_zones").size().to_dict() == {False: 8, True: 4}
    summary = pd.read_csv(out / "summary.csv")
    ratios = summary[summary.metric == "last_third_ratio"]
    assert sorted(zip(ratios.scenario, ratios.policy, strict=True)) == [
        ("comm-temp", "failure_aware"),
        ("comm-temp", "vanilla"),
        ("sensing-temp", "failure_aware"),
        ("sensing-temp", "vanilla"),
    ]
    assert summary[summary.metric == "trace"]["n"].tolist() == [2, 2, 2, 2]  # no reference
    rates = pd.read_csv(out / "win_rates.csv")
    assert sorted(set(rates.kind)) == ["all", "sensing zones only", "with a comm zone"]
    assert set(rates.scenarios) == {1, 2} and set(rates.metric) == {"mse", "nll"}
    assert (rates.wins + rates.ties + rates.losses == rates.scenarios).all()
    report = (out / "report.md").read_text()
    assert "## Scenarios won, tied and lost, by zone kind" in report
    assert "zone-free reference runs of" in report
    assert report.count("| policy | last third ÷ zone-free | stragglers |") == 2


def test_compare_by_zone_kind_needs_two_seeds(tmp_path, capsys):
    argv = ["compare", "sensing-temp", "--seeds", "3-3", "--by-zone-kind"]
    assert main([*argv, "--policies", "failure_aware,vanilla", "--out", str(tmp_path)]) == 1
    assert "--by-zone-kind: needs at least two --seeds" in capsys.readouterr().err


HOSTILE_NAMES = [
    "a.yaml",
    "a-3.yaml",
    "sub/a.yaml",
    "A.yml",
    "...yaml",
    "../scen/mission",
    "UP.YAML",
    "runs.yaml",
    ".hidden.yaml",
    "x y`z.yaml",
]


@pytest.fixture
def hostile_files(tmp_path, monkeypatch):
    """Scenario files whose names collide, climb out or use another case; the folder they are
    given from is ``tmp_path/work``."""
    work = tmp_path / "work"
    text = (SCENARIOS / "sensing-temp.yaml").read_text()
    for name in HOSTILE_NAMES:
        path = work / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    monkeypatch.chdir(work)
    return work


def test_compare_labels_are_unique_and_every_scenario_is_kept(hostile_files):
    study = make_study(HOSTILE_NAMES, ["vanilla"], 1)
    labels = list(study.scenarios)
    assert len(labels) == len(HOSTILE_NAMES)
    assert len({label.casefold() for label in labels}) == len(labels)
    assert [study.sources[label] for label in labels] == HOSTILE_NAMES
    assert labels[:4] == ["a", "a-3", "a-2", "A-4"]  # in the order given, first keeps its name
    assert labels[4:] == ["__", "mission", "UP", "runs-2", "_hidden", "x_y_z"]
    assert {t.experiment for t in study.tasks()} == set(labels)


def test_compare_writes_nothing_outside_its_folder_whatever_the_names(hostile_files):
    from resilient_tracking.experiments.comparison import files_of_report
    from resilient_tracking.experiments.sweep import run_dir

    study = make_study(HOSTILE_NAMES, ["vanilla"], 1)
    out = hostile_files / "out"
    root = out.resolve()
    paths = [run_dir(out, t) for t in study.tasks()]
    paths += [out / name for name in files_of_report(study).folders]
    for path in paths:
        resolved = path.resolve()
        assert resolved.is_relative_to(root) and resolved != root, path
        assert resolved.relative_to(root).parts[0] not in ("report.md", "summary.csv", "runs.csv")
    assert len({p.resolve() for p in paths}) == len(paths)


def test_the_report_names_each_scenario_s_file_beside_its_label(hostile_files):
    from resilient_tracking.experiments.comparison import write_compare_report

    study = make_study(["a.yaml", "sub/a.yaml", "x y`z.yaml", "sensing-temp"], ["vanilla"], 1)
    out = hostile_files / "out"
    report = write_compare_report(study, study.tasks(), out, "rtrack compare").read_text()
    assert "## a\n\nScenario `a.yaml`." in report
    assert "## a-2\n\nScenario `sub/a.yaml`." in report
    assert "## x_y_z\n\nScenario ``x y`z.yaml``." in report
    assert "## sensing-temp\n\n" in report and "Scenario `sensing-temp`" not in report


def test_an_upper_case_suffix_is_a_scenario_file_like_a_lower_case_one(hostile_files, capsys):
    assert list(make_study(["UP.YAML"], ["vanilla"], 1).scenarios) == ["UP"]
    code = main(["compare", "missing.YAML", "--seeds", "1", "--out", "out", "-q"])
    assert code == 1
    assert "missing.YAML" in capsys.readouterr().err
    assert not (hostile_files / "out").exists()


def test_a_label_folder_that_is_a_file_is_refused_by_name_before_anything_runs(
    hostile_files, capsys
):
    """A scenario file given from the --out folder itself, named like its label: the figures
    would go into the file."""
    (hostile_files / "plain").write_text((SCENARIOS / "sensing-temp.yaml").read_text())
    code = main(["compare", "plain", "--seeds", "1", "--policies", "vanilla", "--out", ".", "-q"])
    assert code == 1
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --out: plain: exists and was not written by rtrack"), err
    assert len(err.splitlines()) == 1 and not (hostile_files / "runs").exists()


def test_a_label_folder_that_is_a_link_is_refused_before_anything_runs(hostile_files, capsys):
    elsewhere = hostile_files / "elsewhere"
    elsewhere.mkdir()
    out = hostile_files / "out"
    out.mkdir()
    (out / "a").symlink_to(elsewhere, target_is_directory=True)
    code = main(["compare", "a.yaml", "--seeds", "1", "--policies", "vanilla", "--out", "out"])
    assert code == 1
    assert "out/a: exists and was not written by rtrack" in capsys.readouterr().err
    assert list(elsewhere.iterdir()) == [] and not (out / "runs").exists()
