"""One row per stored run, computed from its saved tables (docs/model.md §8 metrics)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from resilient_tracking.viz.io import RunData, attack_table, load_run


def survival_steps(team: pd.DataFrame, n_robots: int) -> int:
    """Steps until no robot can sense any more (the whole run when one survives)."""
    dead = team.index[team["n_sensing_failed"].to_numpy() >= n_robots]
    return int(team["step"].iloc[dead[0]]) if len(dead) else len(team)


def summarise_run(run: RunData) -> dict[str, Any]:
    team, events = run.team, run.events
    attacks = attack_table(run)
    n_robots = int(run.robots["robot"].nunique())
    tags = run.manifest.get("tags", {}) or {}
    fallbacks = events["event"] == "solver_fallback" if len(events) else pd.Series(dtype=bool)
    return {
        "experiment": run.manifest.get("experiment", ""),
        "variant": run.manifest.get("variant", run.policy),
        "policy": run.policy,
        "seed": run.seed,
        **{f"tag_{k}": v for k, v in tags.items()},
        "robots": n_robots,
        "targets": int(run.targets["target"].nunique()),
        "steps": len(team),
        "trace": float(team["trace"].mean()),
        "mse": float(team["mse"].mean()),
        "final_trace": float(team["trace"].iloc[-1]),
        "effort": float(team["effort"].mean()),
        "sensing_attacks": int((attacks["kind"] == "sensing").sum()),
        "comm_attacks": int((attacks["kind"] == "comm").sum()),
        "robots_attacked": int(attacks["robot"].nunique()),
        "sensing_failed_end": int(team["n_sensing_failed"].iloc[-1]),
        "survival_steps": survival_steps(team, n_robots),
        "zones_inferred": int((events["event"] == "zone_inferred").sum()) if len(events) else 0,
        "solver_failures": int(team["n_solver_failures"].sum())
        if "n_solver_failures" in team
        else 0,
        "solver_fallbacks": int(np.sum(fallbacks)),
    }


def summarise_runs(run_dirs: list[Path]) -> pd.DataFrame:
    """The summary table of many run folders (sorted for stable reports)."""
    rows = [summarise_run(load_run(d)) for d in run_dirs]
    df = pd.DataFrame(rows)
    return df.sort_values(["experiment", "variant", "seed"]).reset_index(drop=True) if rows else df
