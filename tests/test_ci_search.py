"""The side-by-side bounded search gives SciPy's bounded search's numbers bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from resilient_tracking.belief.ci_search import bounded_minimize
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.fusion import covariance_intersection, fuse_estimates


def _functions(rng: np.random.Generator, n: int) -> list:
    """Convex, flat, kinked and one-sided scalar functions on [0, 1]."""
    out = []
    for k in range(n):
        c, w = rng.uniform(-0.5, 1.5), 10.0 ** rng.uniform(-3, 2)
        kind = k % 4
        if kind == 0:
            out.append(lambda x, c=c, w=w: w * (x - c) ** 2)
        elif kind == 1:
            out.append(lambda x, c=c: abs(x - c) + 0.1 * x)
        elif kind == 2:
            out.append(lambda x, c=c: np.cosh(3 * (x - c)))
        else:
            out.append(lambda x: 1.0)  # flat: ties everywhere
    return out


@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("xatol", [1e-5, 1e-8])
def test_side_by_side_searches_end_where_scipys_do(seed: int, xatol: float) -> None:
    rng = np.random.default_rng(seed)
    functions = _functions(rng, 13)

    def objective(x: np.ndarray, rows: np.ndarray) -> np.ndarray:
        picked = [f for f, use in zip(functions, rows, strict=True) if use]
        return np.array([f(float(v)) for f, v in zip(picked, x, strict=True)])

    at, found = bounded_minimize(objective, len(functions), xatol=xatol)
    for k, f in enumerate(functions):
        res = minimize_scalar(f, bounds=(0.0, 1.0), method="bounded", options={"xatol": xatol})
        assert at[k] == res.x and found[k] == res.fun, k


def test_fusing_many_targets_equals_fusing_each_alone() -> None:
    rng = np.random.default_rng(4)

    def spd() -> np.ndarray:
        a = rng.normal(size=(4, 4)) * 10.0 ** rng.uniform(-2, 1)
        return a @ a.T + 1e-3 * np.eye(4)

    c1, c2 = np.stack([spd() for _ in range(9)]), np.stack([spd() for _ in range(9)])
    c2[3] = c1[3]  # equal covariances: the shortcut
    m1, m2 = rng.normal(size=(9, 4)), rng.normal(size=(9, 4))
    fused, weights = fuse_estimates(TargetEstimate(m1, c1), TargetEstimate(m2, c2))
    for j in range(9):
        mean, cov, lam = covariance_intersection(m1[j], c1[j], m2[j], c2[j])
        assert weights[j] == lam
        np.testing.assert_array_equal(fused.mean[j], mean)
        np.testing.assert_array_equal(fused.cov[j], cov)
