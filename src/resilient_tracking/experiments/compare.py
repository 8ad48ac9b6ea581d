"""Side-by-side comparison of policies on scenarios over seeds (time-averaged metrics)."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path

import pandas as pd
from joblib import Parallel, delayed

from resilient_tracking.scenario import Scenario, load_scenario
from resilient_tracking.sim.episode import run_episode


def summarise(scenario: Scenario, policy: str, seed: int) -> dict[str, object]:
    """One episode reduced to one row: time-averaged trace and MSE, failures, solver trouble."""
    result = run_episode(scenario, policy=policy, seed=seed)
    team, events = result["team"], result["events"]
    attacks = events[events["event"] == "attack"] if len(events) else events
    return {
        "scenario": scenario.name,
        "policy": policy,
        "seed": seed,
        "trace": float(team["trace"].mean()),
        "mse": float(team["mse"].mean()),
        "final_trace": float(team["trace"].iloc[-1]),
        "attacks": len(attacks),
        "robots_attacked": int(attacks["robot"].nunique()) if len(attacks) else 0,
        "zones_inferred": int((events["event"] == "zone_inferred").sum()) if len(events) else 0,
        "solver_failures": int(team["n_solver_failures"].sum()),
    }


def compare(
    scenario_paths: Iterable[str | Path],
    policies: Iterable[str],
    seeds: Iterable[int],
    jobs: int = 1,
) -> pd.DataFrame:
    """One row per (scenario, policy, seed)."""
    scenarios = [load_scenario(p) for p in scenario_paths]
    tasks = [(s, p, seed) for s in scenarios for p in policies for seed in seeds]
    rows = Parallel(n_jobs=jobs)(delayed(summarise)(*t) for t in tasks)
    return pd.DataFrame(rows)
