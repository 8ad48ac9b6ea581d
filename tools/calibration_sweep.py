"""Compare both policies on shipped scenarios with dotted-path overrides (calibration sweeps).

Usage (from the repository root)::

    python tools/calibration_sweep.py comm-temp,comm-perm --seeds 1-10 \\
        --case 'shipped={}' \\
        --case 'compact={"zones.0.sigma": [[0.05, 0], [0, 0.05]], "zones.0.hazard.kappa": 0.628}' \\
        --case 'margin0={"policy.failure_aware.circle_margin": 0.0}'

Each ``--case`` is ``label=JSON`` where the JSON maps dotted paths of the scenario file
(``zones.0.mu``, ``policy.failure_aware.eps2``, ``policy.vanilla.w_effort``…) to values; a key
may be prefixed by ``scenario-name:`` to apply to one scenario only. The scenario files are not
modified. Prints, per case and scenario, the mean time-averaged trace and MSE of each policy,
robots attacked, zones inferred, the failure-aware/vanilla trace ratio and the number of seeds
the failure-aware policy wins.
"""

from __future__ import annotations

import argparse
import json

import pandas as pd
import yaml
from calibration_table import seed_range  # sibling script: tools/ is on sys.path when run
from joblib import Parallel, delayed

from resilient_tracking import scenarios
from resilient_tracking.experiments.compare import summarise
from resilient_tracking.scenario.overrides import apply_overrides

SCENARIOS = scenarios.folder()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenarios", help="comma-separated shipped scenario names")
    parser.add_argument("--case", action="append", default=[], help="label=JSON overrides")
    parser.add_argument("--seeds", default="1-5")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--csv", help="also write the per-seed rows here")
    args = parser.parse_args()
    cases = [c.split("=", 1) for c in (args.case or ["shipped={}"])]
    tasks = []
    for label, text in cases:
        overrides = json.loads(text)
        for name in args.scenarios.split(","):
            data = yaml.safe_load((SCENARIOS / f"{name}.yaml").read_text())
            mine = {}
            for key, value in overrides.items():
                scope, _, path = key.rpartition(":")
                if scope in ("", name):
                    mine[path] = value
            scenario = apply_overrides(data, mine, f"{name} [{label}]")
            for policy in ("vanilla", "failure_aware"):
                tasks += [(label, scenario, policy, s) for s in seed_range(args.seeds)]
    rows = Parallel(n_jobs=args.jobs)(
        delayed(lambda lab, sc, p, s: {"case": lab, **summarise(sc, p, s)})(*t) for t in tasks
    )
    df = pd.DataFrame(rows)
    if args.csv:
        df.to_csv(args.csv, index=False)
    per_seed = df.pivot_table(index=["case", "scenario", "seed"], columns="policy", values="trace")
    wins = (per_seed["failure_aware"] < per_seed["vanilla"]).groupby(level=[0, 1]).sum()
    table = df.pivot_table(
        index=["case", "scenario"],
        columns="policy",
        values=["trace", "mse", "robots_attacked", "zones_inferred"],
        aggfunc="mean",
    )
    table.columns = [
        f"{metric}_{'fa' if p == 'failure_aware' else 'va'}" for metric, p in table.columns
    ]
    table["ratio"] = table["trace_fa"] / table["trace_va"]
    table["fa_wins"] = wins
    pd.set_option("display.width", 250)
    print(table.round(4).to_string())


if __name__ == "__main__":
    main()
