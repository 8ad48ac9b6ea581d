"""Fusing two leagues' estimates (covariance intersection): all targets at once against one
target at a time, side by side in one run.

    python -m benchmarks.fusion            # 5, 20 and 40 targets, 50 repeats
    python -m benchmarks.fusion --quick    # 10 repeats

When leagues merge, their estimates of every target are fused by covariance intersection,
each target's weight found by a bounded scalar search (docs/model.md §4). ``fuse_estimates``
runs the searches of all targets together; ``one at a time`` is ``covariance_intersection``
per target (SciPy's search each). Both give the same numbers (checked here, bit for bit).
Random 4-state estimates from a fixed seed; reported: the median time per fusion and the
ratio.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import numpy as np

from benchmarks.common import machine, save, summary_ms, table
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.fusion import covariance_intersection, fuse_estimates

SIZES = (5, 20, 40)


def estimates(n: int, seed: int = 4) -> tuple[TargetEstimate, TargetEstimate]:
    """Two estimates of ``n`` targets with random positive-definite covariances."""
    rng = np.random.default_rng(seed)

    def spd() -> np.ndarray:
        a = rng.normal(size=(4, 4)) * 10.0 ** rng.uniform(-2, 1)
        return a @ a.T + 1e-3 * np.eye(4)

    covs = [np.stack([spd() for _ in range(n)]) for _ in range(2)]
    means = [rng.normal(size=(n, 4)) for _ in range(2)]
    return TargetEstimate(means[0], covs[0]), TargetEstimate(means[1], covs[1])


def one_at_a_time(a: TargetEstimate, b: TargetEstimate) -> np.ndarray:
    """The weights of ``covariance_intersection`` target by target."""
    return np.array(
        [
            covariance_intersection(a.mean[j], a.cov[j], b.mean[j], b.cov[j])[2]
            for j in range(len(a.mean))
        ]
    )


def measure(n: int, repeats: int) -> dict[str, Any]:
    a, b = estimates(n)
    _, together = fuse_estimates(a, b)
    if not np.array_equal(np.asarray(together), one_at_a_time(a, b)):
        raise AssertionError(f"{n} targets: the fused weights differ from one search per target")
    times: dict[str, list[float]] = {"together": [], "one at a time": []}
    for _ in range(repeats):  # alternately
        started = time.perf_counter()
        fuse_estimates(a, b)
        times["together"].append(1e3 * (time.perf_counter() - started))
        started = time.perf_counter()
        one_at_a_time(a, b)
        times["one at a time"].append(1e3 * (time.perf_counter() - started))
    return {name: summary_ms(values) for name, values in times.items()}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args(argv)
    repeats = 10 if args.quick else 50
    results = {n: measure(n, repeats) for n in SIZES}
    rows = [
        [
            n,
            r["together"]["median"],
            r["one at a time"]["median"],
            r["one at a time"]["median"] / r["together"]["median"],
        ]
        for n, r in results.items()
    ]
    print(table(rows, ["targets", "together ms", "one at a time ms", "speed-up"]))
    path = save("fusion", {"machine": machine(), "repeats": repeats, "results": results})
    print(f"saved {path}")


if __name__ == "__main__":
    main()
