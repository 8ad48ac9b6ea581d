"""Consistency of stored runs: the mean position NEES of the team estimate per variant, with the
two-sided 95 % band of a consistent estimate (docs/adversarial.md).

    rtrack reproduce adversarial --jobs 2 --out results
    python tools/run_nees.py results/runs/adversarial evasive-open evasive-zones

A variant folder holds one run folder per seed (``<experiment>/<variant>/seed-NNN``). The NEES
of one target at one step is ``(x − x̂)²/σx² + (y − ŷ)²/σy²`` from the ``targets`` table (the
team estimate's marginal variances); it has mean 2 when the estimate is consistent. A variant's
value is the mean over its runs' steps and targets. The band is that of the mean of ``n``
independent χ²(2) values, ``n`` the variant's runs × targets: conservative for time averages,
whose samples are positively correlated but many more.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from resilient_tracking.runs.reading import load_run


def position_nees(run_dir: Path) -> tuple[float, int]:
    """A run's mean position NEES over steps and targets, and its number of targets."""
    t = load_run(run_dir).targets
    nees = (t.x - t.est_x) ** 2 / t.var_x + (t.y - t.est_y) ** 2 / t.var_y
    return float(nees.mean()), int(t.target.nunique())


def band(n: int) -> tuple[float, float]:
    """The two-sided 95 % interval of the mean of ``n`` independent χ²(2) values."""
    lo, hi = chi2.ppf([0.025, 0.975], 2 * n) / n
    return float(lo), float(hi)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("folder", type=Path, help="an experiment's folder of variant folders")
    parser.add_argument("scenarios", nargs="*", help="only variants whose name starts so")
    args = parser.parse_args(argv)
    variants = sorted(p for p in args.folder.iterdir() if p.is_dir())
    if args.scenarios:
        variants = [v for v in variants if v.name.startswith(tuple(args.scenarios))]
    if not variants:
        print(f"error: no variant folders in {args.folder}", file=sys.stderr)
        return 1
    print("| variant | runs | position NEES | seeds (min–max) | 95 % band |")
    print("|---|---|---|---|---|")
    for variant in variants:
        runs = [position_nees(r) for r in sorted(variant.glob("seed-*"))]
        if not runs:
            continue
        values = [v for v, _ in runs]
        lo, hi = band(sum(n for _, n in runs))
        print(
            f"| {variant.name} | {len(runs)} | {np.mean(values):.2f} | "
            f"{min(values):.2f}–{max(values):.2f} | [{lo:.2f}, {hi:.2f}] |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
