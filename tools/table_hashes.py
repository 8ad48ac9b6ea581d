"""Fingerprints of the reproducible run tables, to prove a refactor changed no result.

``python tools/table_hashes.py --write`` records the SHA-256 of every bit-for-bit table of a
fixed set of runs (every shipped paper and benchmark scenario with every policy) into
``tests/data/golden_tables.json``; ``tests/test_golden_tables.py`` re-runs them and compares.
Every run uses the paper's one-step planner program.

Bit for bit holds on one kind of CPU: OpenBLAS picks its kernels by CPU (and NumPy its SIMD
loops), and an AVX-512 kernel rounds differently from an AVX2 one. So the fingerprints are
taken with both pinned (:data:`PINNED_ENV`, set before NumPy loads: the script re-runs itself
with it), which any x86-64 CPU with AVX2 and FMA runs alike.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
from pathlib import Path

import pandas as pd

from resilient_tracking import scenarios
from resilient_tracking.scenario import Scenario, load_scenario
from resilient_tracking.sim.episode import run_episode
from resilient_tracking.sim.kernels import PINNED_ENV, pinned
from resilient_tracking.sim.records import TABLES

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "tests" / "data" / "golden_tables.json"
SHIPPED = (
    "sensing-temp",
    "sensing-perm",
    "comm-temp",
    "comm-perm",
    "combined-temp",
    "combined-perm",
    "bench-risk",
    "bench-scale",
    "bench-complex",
)
SEED = 7
#: (scenario, policy) pairs fingerprinted, each over the scenario's full length at SEED.
RUNS: list[tuple[str, str]] = [
    (name, policy) for name in SHIPPED for policy in ("failure_aware", "vanilla", "sog")
]


def table_hash(df: pd.DataFrame) -> str:
    """SHA-256 over column names, dtypes and every value (row order matters)."""
    h = hashlib.sha256()
    h.update(repr([(c, str(t)) for c, t in df.dtypes.items()]).encode())
    h.update(pd.util.hash_pandas_object(df, index=True).to_numpy().tobytes())
    return h.hexdigest()


def paper_program(scenario: Scenario) -> Scenario:
    """The scenario on the paper's one-step program, where the program is a choice."""
    data = scenario.model_dump(mode="python")
    if "program" in data.get("planner", {}):
        data["planner"]["program"] = "one_step"
    return Scenario.model_validate(data)


def fingerprints(runs: list[tuple[str, str]] = RUNS) -> dict[str, dict[str, str]]:
    out: dict[str, dict[str, str]] = {}
    for name, policy in runs:
        scenario = paper_program(load_scenario(scenarios.path(name)))
        result = run_episode(scenario, policy=policy, seed=SEED)
        out[f"{name}/{policy}"] = {t: table_hash(result.tables[t]) for t in TABLES}
    return out


def main() -> None:
    if not pinned():  # re-run with the kernels pinned (replaces this process)
        os.execve(sys.executable, [sys.executable, *sys.argv], {**os.environ, **PINNED_ENV})
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--write", action="store_true", help=f"record into {GOLDEN}")
    parser.add_argument("--json", action="store_true", help="print the fingerprints as JSON")
    parser.add_argument(
        "--policy",
        choices=sorted({policy for _, policy in RUNS}),
        help="only the runs of this policy (with --write: re-record only their entries)",
    )
    args = parser.parse_args()
    found = fingerprints([r for r in RUNS if args.policy in (None, r[1])])
    if args.json:
        print(json.dumps(found))
        return
    if args.write:
        recorded = json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {}
        recorded.update(found)
        GOLDEN.write_text(json.dumps(recorded, indent=1, sort_keys=True) + "\n")
        print(f"wrote {GOLDEN}")
        return
    golden = json.loads(GOLDEN.read_text())
    for key, tables in found.items():
        diff = [t for t in tables if golden.get(key, {}).get(t) != tables[t]]
        print(f"{key}: {'same' if not diff else 'DIFFERENT ' + ', '.join(diff)}")


if __name__ == "__main__":
    main()
