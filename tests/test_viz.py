"""Figures from a synthetic run folder (no simulator involved)."""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.image as mpimg  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402
from matplotlib.backends.backend_agg import FigureCanvasAgg  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402

from resilient_tracking.runs.schema import TABLES  # noqa: E402
from resilient_tracking.viz import (  # noqa: E402
    attack_table,
    known_zones_at,
    load_run,
    make_run_figures,
    plot_trajectory_map,
    wants_log_scale,
)
from resilient_tracking.viz.sweeps import band  # noqa: E402

N_STEPS = 50
N_ROBOTS = 3
N_TARGETS = 2
DT = 0.1

KNOWLEDGE_COLUMNS = [
    "step",
    "robot",
    "zone",
    "kind",
    "source",
    "x",
    "y",
    "sigma_xx",
    "sigma_xy",
    "sigma_yy",
    "size",
]


def declared(name: str, df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with every column the declaration gives table ``name`` (those it lacks filled
    with an empty value of the declared dtype), extra columns kept."""
    empty = {"int64": -1, "float64": np.nan, "bool": False, "str": ""}
    missing = {c.name: empty[c.dtype] for c in TABLES[name].columns if c.name not in df}
    return df.assign(**missing)


def _knowledge_rows() -> pd.DataFrame:
    rows = [
        # step, robot, zone, kind, source, x, y, sxx, sxy, syy, size
        (15, 0, 0, "sensing", "attack_clue", 4.2, 4.8, 0.3, 0.0, 0.3, 0.8),
        (16, 1, 0, "sensing", "broadcast", 4.2, 4.8, 0.3, 0.0, 0.3, 0.8),
        (30, 1, 1, "comm", "attack_clue", 7.0, 3.0, 0.5, 0.1, 0.4, 0.3),
        (40, 2, 0, "sensing", "observed_circle", 4.05, 4.95, 0.1, 0.02, 0.08, 0.8),
    ]
    return pd.DataFrame(rows, columns=KNOWLEDGE_COLUMNS).astype(
        {"step": "int64", "robot": "int64", "zone": "int64"}
    )


def write_run(run_dir: Path, *, empty_knowledge: bool = False, workspace: bool = True) -> Path:
    """Write a plausible 3-robot, 2-target, 1 sensing + 1 comm zone run of 50 steps."""
    run_dir.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    steps = np.arange(N_STEPS)
    time = steps * DT

    # Robots: move right at different heights; robot 0 is stuck after its sensing attack.
    robot_rows = []
    for r in range(N_ROBOTS):
        x, y = 1.0, 2.0 + 1.5 * r
        for k in steps:
            ux, uy = (0.0, 0.0) if (r == 0 and k >= 15) else (1.0, 0.3 * np.sin(0.2 * k + r))
            robot_rows.append(
                {
                    "step": int(k),
                    "robot": r,
                    "x": x,
                    "y": y,
                    "ux": ux,
                    "uy": uy,
                    "sensing_ok": not (r == 0 and 15 <= k < 25),
                    "comm_ok": not (r == 1 and k >= 30),
                    "league": 0 if not (r == 1 and k >= 30) else 1,
                    "mode": "circular" if (r == 1 and k >= 30) else "league",
                }
            )
            x, y = x + ux * DT * 1.5, y + uy * DT
    robots = pd.DataFrame(robot_rows)

    target_rows = []
    for j in range(N_TARGETS):
        for k in steps:
            tx, ty = 2.0 + 0.14 * k, 5.0 + 1.5 * j + 0.5 * np.sin(0.1 * k)
            var = 0.05 + (0.5 if 15 <= k < 25 else 0.0)
            target_rows.append(
                {
                    "step": int(k),
                    "target": j,
                    "x": tx,
                    "y": ty,
                    "est_x": tx + rng.normal(0, np.sqrt(var)),
                    "est_y": ty + rng.normal(0, np.sqrt(var)),
                    "var_x": var,
                    "var_y": var,
                }
            )
    targets = pd.DataFrame(target_rows)

    n_sens = robots.groupby("step")["sensing_ok"].apply(lambda s: int((~s).sum())).to_numpy()
    n_comm = robots.groupby("step")["comm_ok"].apply(lambda s: int((~s).sum())).to_numpy()
    team = pd.DataFrame(
        {
            "step": steps,
            "time": time,
            "mse": 0.05 + 0.5 * (n_sens > 0) + rng.uniform(0, 0.02, N_STEPS),
            # grows by > 2 decades to exercise the log axis
            "trace": 0.02 * np.exp(0.12 * steps),
            "effort": robots.assign(n=np.hypot(robots.ux, robots.uy)).groupby("step")["n"].sum(),
            "n_sensing_failed": n_sens,
            "n_comm_failed": n_comm,
            "n_leagues": 1 + (n_comm > 0),
            "plan_ms": rng.uniform(5, 15, N_STEPS),
        }
    )

    events = pd.DataFrame(
        [
            (15, 0, "attack", "sensing zone0 temporary (hazard)", "sensing", 0, "temporary"),
            (15, 0, "zone_learned", "zone0 sensing via attack", "sensing", 0, "temporary"),
            (25, 0, "recover", "sensing", "sensing", -1, ""),
            (30, 1, "attack", "comm zone1 permanent (hazard)", "comm", 1, "permanent"),
            (30, -1, "league_split", "league [1] split off", "", -1, ""),
            (42, 2, "attack", "sensing zone0 temporary (hazard)", "sensing", 0, "temporary"),
        ],
        columns=["step", "robot", "event", "detail", "kind", "zone", "persistence"],
    )

    zones = pd.DataFrame(
        [
            (0, "S1", "sensing", "temporary", 4.2, 4.8, 0.3, 0.0, 0.3, 0.8, 4.0, 5.0),
            (1, "C1", "comm", "permanent", 7.0, 3.0, 0.5, 0.1, 0.4, 0.3, 6.7, 3.2),
        ],
        columns=[
            "zone",
            "name",
            "kind",
            "persistence",
            "mu_x",
            "mu_y",
            "sigma_xx",
            "sigma_xy",
            "sigma_yy",
            "size",
            "true_x",
            "true_y",
        ],
    )

    knowledge = _knowledge_rows()
    if empty_knowledge:
        knowledge = knowledge.iloc[0:0]

    for name, df in {
        "team": team,
        "robots": robots,
        "targets": targets,
        "events": events,
        "zones": zones,
        "knowledge": knowledge,
    }.items():
        declared(name, df).to_parquet(run_dir / f"{name}.parquet", index=False)

    scenario: dict[str, object] = {"name": "synthetic-combined", "dt": DT}
    if workspace:
        scenario["workspace"] = {"xmin": 0.0, "xmax": 10.0, "ymin": 0.0, "ymax": 10.0}
    manifest = {"scenario": scenario, "seed": 7, "policy": "adaptive", "version": "0.1.0"}
    (run_dir / "manifest.json").write_text(json.dumps(manifest), encoding="utf-8")
    return run_dir


def assert_nontrivial_png(path: Path, min_kb: float = 20.0) -> None:
    assert path.exists(), path
    assert path.suffix == ".png"
    assert path.stat().st_size > min_kb * 1024, f"{path} is only {path.stat().st_size} bytes"
    img = mpimg.imread(path)
    colours = np.unique(img.reshape(-1, img.shape[-1]), axis=0)
    assert len(colours) > 10, f"{path} has only {len(colours)} distinct colours"


@pytest.mark.slow
@pytest.mark.parametrize("empty_knowledge", [False, True])
def test_make_run_figures_writes_pngs(tmp_path: Path, empty_knowledge: bool) -> None:
    run_dir = write_run(tmp_path / "run", empty_knowledge=empty_knowledge)
    paths = make_run_figures(run_dir)
    assert len(paths) == 2
    assert {p.name for p in paths} == {"trajectories.png", "metrics.png"}
    for p in paths:
        assert p.parent == run_dir / "figures"
        assert_nontrivial_png(p)


@pytest.mark.slow
def test_make_run_figures_without_workspace_or_optional_tables(tmp_path: Path) -> None:
    run_dir = write_run(tmp_path / "run", workspace=False)
    (run_dir / "events.parquet").unlink()
    (run_dir / "knowledge.parquet").unlink()
    for p in make_run_figures(run_dir):
        assert_nontrivial_png(p)


def test_known_zones_at_filters_by_step() -> None:
    kb = _knowledge_rows()
    assert known_zones_at(kb, 14).empty
    at15 = known_zones_at(kb, 15)
    assert list(at15["zone"]) == [0]
    assert at15.loc[0, "source"] == "attack_clue"
    at35 = known_zones_at(kb, 35)
    assert list(at35["zone"]) == [0, 1]
    assert at35.loc[0, "step"] == 16  # latest row for zone 0 at or before step 35
    assert at35.loc[1, "kind"] == "comm"
    final = known_zones_at(kb, None)
    assert list(final["zone"]) == [0, 1]
    assert final.loc[0, "source"] == "observed_circle"
    assert final.loc[0, "sigma_xx"] == pytest.approx(0.1)
    assert list(final.columns) == KNOWLEDGE_COLUMNS
    assert known_zones_at(kb, 40).equals(final)


def test_known_zones_at_ties_and_empty() -> None:
    kb = _knowledge_rows()
    tie = kb.iloc[[0]].assign(source="second_writer", x=9.0)
    kb2 = pd.concat([kb, tie], ignore_index=True)  # same step 15, written last
    assert known_zones_at(kb2, 15).loc[0, "source"] == "second_writer"
    empty = kb.iloc[0:0]
    out = known_zones_at(empty, 10)
    assert out.empty
    assert list(out.columns) == KNOWLEDGE_COLUMNS


def test_attack_kinds_are_read_from_the_kind_column(tmp_path: Path) -> None:
    run_dir = write_run(tmp_path / "run")
    events = pd.read_parquet(run_dir / "events.parquet")
    events.assign(detail="").to_parquet(run_dir / "events.parquet", index=False)
    assert list(attack_table(load_run(run_dir))["kind"]) == ["sensing", "comm", "sensing"]
    events.assign(kind="comm").to_parquet(run_dir / "events.parquet", index=False)
    assert list(attack_table(load_run(run_dir))["kind"]) == ["comm"] * 3


def test_a_run_with_old_untyped_events_is_named_old(tmp_path: Path) -> None:
    run_dir = write_run(tmp_path / "run")
    old = pd.read_parquet(run_dir / "events.parquet")[["step", "robot", "event", "detail"]]
    old.to_parquet(run_dir / "events.parquet", index=False)
    with pytest.raises(
        ValueError, match=r"events\.parquet: missing columns \['kind'.*run it again"
    ):
        load_run(run_dir)


def test_load_run_and_attack_table(tmp_path: Path) -> None:
    run = load_run(write_run(tmp_path / "run"))
    assert run.scenario_name == "synthetic-combined"
    assert run.policy == "adaptive"
    assert run.seed == 7
    assert run.dt == pytest.approx(DT)
    assert run.workspace == (0.0, 10.0, 0.0, 10.0)
    assert run.last_step == N_STEPS - 1
    att = attack_table(run)
    assert list(att["kind"]) == ["sensing", "comm", "sensing"]
    assert att[["x", "y"]].notna().all().all()
    robot1_at_30 = run.robots[(run.robots.step == 30) & (run.robots.robot == 1)]
    assert att.loc[1, "x"] == pytest.approx(float(robot1_at_30["x"].iloc[0]))
    assert len(attack_table(run, until_step=29)) == 1
    assert run.times_of([10, 20]) == pytest.approx([1.0, 2.0])


def test_load_run_reports_missing_column(tmp_path: Path) -> None:
    run_dir = write_run(tmp_path / "run")
    pd.read_parquet(run_dir / "team.parquet").drop(columns=["trace"]).to_parquet(
        run_dir / "team.parquet"
    )
    with pytest.raises(ValueError, match=r"team\.parquet.*trace"):
        load_run(run_dir)


def test_load_run_missing_required_table(tmp_path: Path) -> None:
    run_dir = write_run(tmp_path / "run")
    (run_dir / "zones.parquet").unlink()
    with pytest.raises(FileNotFoundError, match="zones.parquet"):
        load_run(run_dir)


@pytest.mark.slow
def test_trajectory_map_into_given_axes_snapshot_panels(tmp_path: Path) -> None:
    run = load_run(write_run(tmp_path / "run"))
    fig = Figure(figsize=(12, 4))
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 3)
    for ax, step in zip(axes, (10, 20, 45), strict=True):
        returned = plot_trajectory_map(run, None, until_step=step, ax=ax, legend=False)
        assert returned is ax
        assert ax.get_legend() is None
        assert ax.get_aspect() == 1.0
    labels_early = axes[0].get_legend_handles_labels()[1]
    labels_late = axes[2].get_legend_handles_labels()[1]
    assert "sensing attack" not in labels_early
    assert "sensing attack" in labels_late and "comm attack" in labels_late
    assert not any(lbl.startswith("known") for lbl in labels_early)
    assert any(lbl.startswith("known sensing") for lbl in labels_late)
    out = tmp_path / "snap.png"
    fig.savefig(out, dpi=80)
    assert_nontrivial_png(out, min_kb=5)


@pytest.mark.slow
def test_trajectory_map_until_step_writes_file(tmp_path: Path) -> None:
    run = load_run(write_run(tmp_path / "run"))
    out = tmp_path / "sub" / "map_step20.png"
    ax = plot_trajectory_map(run, out, until_step=20)
    assert "step 20" in ax.get_title()
    assert_nontrivial_png(out)


def test_wants_log_scale() -> None:
    assert wants_log_scale([0.01, 0.1, 5.0])
    assert not wants_log_scale([0.5, 1.0, 40.0])
    assert not wants_log_scale([0.0, 0.0, 1.0])  # non-positive values ignored
    assert not wants_log_scale([np.nan, 1.0])


def test_sixty_four_robots_get_sixty_four_distinct_colours():
    from matplotlib.colors import to_rgb

    from resilient_tracking.scenario import MAX_ROBOTS
    from resilient_tracking.viz.trajectories import COMM_COLOR, SENSING_COLOR, robot_color

    colors = np.array([to_rgb(robot_color(i)) for i in range(MAX_ROBOTS)])
    gaps = np.linalg.norm(colors[:, None] - colors[None], axis=-1) + 9 * np.eye(MAX_ROBOTS)
    assert gaps.min() > 0.15  # no two robots look alike
    for reserved in (SENSING_COLOR, COMM_COLOR):  # red and cyan keep their meanings
        assert np.linalg.norm(colors - np.array(to_rgb(reserved)), axis=1).min() > 0.15
    assert robot_color(0) == "tab:blue"  # the first ten are unchanged


def test_a_positive_metrics_band_stops_at_the_smallest_value_seen() -> None:
    """An MSE that is tiny in one seed and large in another has mean − std below zero; on a
    log axis its band stops at the smallest value seen, not at the smallest float."""
    values = np.array([[1e-4, 2e-4, 1e-3], [1.0, 2.0, 3.0]])
    mean, low, high = band(values, positive=True)
    np.testing.assert_allclose(mean, values.mean(axis=0))
    np.testing.assert_allclose(high, mean + values.std(axis=0))
    assert (low >= 1e-4).all() and (low <= mean).all()
    effort, _, _ = band(values, positive=False)
    _, signed_low, _ = band(-values, positive=False)
    assert (signed_low < 0).all() and np.array_equal(effort, mean)
