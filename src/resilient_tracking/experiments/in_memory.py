"""Side-by-side comparison of policies on scenarios over seeds, without writing run folders.

Each episode is reduced in memory to the row :func:`~resilient_tracking.experiments.summary.
summarise_run` gives a stored run (time-averaged trace and MSE, attacks, survival, solver
trouble), plus its scenario's name. The paper-claims and route-program tests use it;
``rtrack compare`` and ``rtrack reproduce`` store their runs and summarise them from disk
instead.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd
from joblib import Parallel, delayed

from resilient_tracking.experiments.summary import summarise_run
from resilient_tracking.runs.reading import run_data
from resilient_tracking.scenario import Scenario, load_scenario
from resilient_tracking.scenario.overrides import overridden
from resilient_tracking.sim.episode import run_episode


def summarise(scenario: Scenario, policy: str, seed: int) -> dict[str, Any]:
    """One episode reduced to one row."""
    result = run_episode(scenario, policy=policy, seed=seed)
    return {"scenario": scenario.name, **summarise_run(run_data(result, scenario.name))}


def compare(
    scenario_paths: Iterable[str | Path],
    policies: Iterable[str],
    seeds: Iterable[int],
    jobs: int = 1,
    overrides: Mapping[str, Any] | None = None,
) -> pd.DataFrame:
    """One row per (scenario, policy, seed); ``overrides`` change every scenario by dotted
    path (``{"planner.program": "one_step"}``)."""
    scenarios = [overridden(load_scenario(p), overrides or {}) for p in scenario_paths]
    tasks = [(s, p, seed) for s in scenarios for p in policies for seed in seeds]
    rows = Parallel(n_jobs=jobs)(delayed(summarise)(*t) for t in tasks)
    return pd.DataFrame(rows)
