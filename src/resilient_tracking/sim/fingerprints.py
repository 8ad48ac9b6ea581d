"""Fingerprints of the reproducible run tables, to prove a refactor changed no result.

``python -m resilient_tracking.sim.fingerprints --write`` records the SHA-256 of every
bit-for-bit table (:data:`~resilient_tracking.runs.schema.REPRODUCIBLE`) of a fixed set of runs
(every shipped paper and benchmark scenario with every policy) into the golden file
(``tests/data/golden_tables.json`` of the repository); without ``--write`` it re-runs them and
prints ``same`` or ``DIFFERENT <tables>`` per run. ``tests/test_golden_tables.py`` compares
the same way. Every run uses the paper's one-step planner program.

The golden file also records, under ``"_columns"``, the columns of each table it fingerprints
(those the tables had when it was written): a column added since is left out of the comparison,
so adding one leaves the golden runs as they were, and every column that was there must still
be bit for bit.

Bit for bit holds on one kind of CPU: OpenBLAS picks its kernels by CPU (and NumPy its SIMD
loops), and an AVX-512 kernel rounds differently from an AVX2 one. So the fingerprints are
taken with both pinned (:data:`~resilient_tracking.kernels.PINNED_ENV`, set before NumPy
loads: the command re-runs itself with it), which any x86-64 CPU with AVX2 and FMA runs alike.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from resilient_tracking import builtin_scenarios
from resilient_tracking.kernels import PINNED_ENV, pinned
from resilient_tracking.runs.schema import REPRODUCIBLE, TABLES
from resilient_tracking.scenario import Scenario, load_scenario
from resilient_tracking.sim.episode import run_episode

MODULE = "resilient_tracking.sim.fingerprints"

#: The golden file, relative to the repository's root.
GOLDEN = Path("tests") / "data" / "golden_tables.json"
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
#: The golden file's entry naming the columns fingerprinted per table.
COLUMNS_KEY = "_columns"
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


def fingerprinted_scenario(name: str) -> Scenario:
    """Shipped scenario ``name`` run by the ``paper`` team: the paper's method as written (its
    one-step program and constraint set)."""
    return load_scenario(builtin_scenarios.path(name)).with_team("paper")


def fingerprints(
    runs: Sequence[tuple[str, str]] = RUNS, columns: dict[str, list[str]] | None = None
) -> dict[str, dict[str, str]]:
    """``"<scenario>/<policy>"`` → table name → fingerprint, for each of ``runs``, of the
    ``columns`` of each table they name (every reproducible table, whole, when none given)."""
    columns = columns or {}
    out: dict[str, dict[str, str]] = {}
    for name, policy in runs:
        result = run_episode(fingerprinted_scenario(name), policy=policy, seed=SEED)
        out[f"{name}/{policy}"] = {
            t: table_hash(result.tables[t][columns.get(t, list(result.tables[t].columns))])
            for t in REPRODUCIBLE
            if not columns or t in columns
        }
    return out


def recorded_columns(golden: dict[str, object]) -> dict[str, list[str]]:
    """The columns per table a golden file fingerprints (none named: every column)."""
    found = golden.get(COLUMNS_KEY, {})
    return dict(found) if isinstance(found, dict) else {}


def differences(found: dict[str, dict[str, str]], golden: dict[str, dict[str, str]]) -> list[str]:
    """One line per run: ``<run>: same`` or ``<run>: DIFFERENT <tables>``."""
    lines = []
    for key, tables in found.items():
        diff = [t for t in tables if golden.get(key, {}).get(t) != tables[t]]
        lines.append(f"{key}: {'same' if not diff else 'DIFFERENT ' + ', '.join(diff)}")
    return lines


def main(argv: Sequence[str] | None = None) -> None:
    """The command line; re-runs itself with the kernels pinned first."""
    args_list = list(sys.argv[1:] if argv is None else argv)
    if not pinned():  # re-run with the kernels pinned (replaces this process)
        command = [sys.executable, "-m", MODULE, *args_list]
        os.execve(sys.executable, command, {**os.environ, **PINNED_ENV})
    parser = argparse.ArgumentParser(prog=f"python -m {MODULE}", description=__doc__)
    parser.add_argument("--golden", type=Path, default=GOLDEN, help="the golden file")
    parser.add_argument("--write", action="store_true", help="record into the golden file")
    parser.add_argument("--json", action="store_true", help="print the fingerprints as JSON")
    parser.add_argument(
        "--policy",
        choices=sorted({policy for _, policy in RUNS}),
        help="only the runs of this policy (with --write: re-record only their entries)",
    )
    args = parser.parse_args(args_list)
    golden_path: Path = args.golden
    golden = json.loads(golden_path.read_text()) if golden_path.exists() else {}
    runs = [r for r in RUNS if args.policy in (None, r[1])]
    if args.write:  # every column of today's tables
        columns = {t: TABLES[t].names for t in REPRODUCIBLE}
        if args.policy is not None and recorded_columns(golden) != columns:
            parser.error("--policy re-records some runs only: the golden file's columns differ")
        found = fingerprints(runs, columns)
        recorded = {**golden, **found, COLUMNS_KEY: columns}
        golden_path.write_text(json.dumps(recorded, indent=1, sort_keys=True) + "\n")
        print(f"wrote {golden_path}")
        return
    found = fingerprints(runs, recorded_columns(golden))
    if args.json:
        print(json.dumps(found))
        return
    print("\n".join(differences(found, golden)))


if __name__ == "__main__":
    main()
