"""Covariance intersection for merging league estimates (docs/model.md §4, paper CI eqs.).

``P⁻¹ = λ P₁⁻¹ + (1 − λ) P₂⁻¹``, ``ŷ = P (λ P₁⁻¹ ŷ₁ + (1 − λ) P₂⁻¹ ŷ₂)``, with ``λ ∈ [0, 1]``
minimising ``tr P`` or ``det P``. CI is consistent whatever the (unknown) correlation between the
two estimates, which is why it is used when a robot that tracked alone rejoins its league.
Estimates with motion-mode states (the IMM's) are fused on their combined Gaussians; the mode
states follow (:func:`fuse_estimates`).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize_scalar

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.modes import ModeStates, pooled

FloatArray = NDArray[np.float64]
Criterion = Literal["trace", "det"]


def covariance_intersection(
    mean1: FloatArray,
    cov1: FloatArray,
    mean2: FloatArray,
    cov2: FloatArray,
    criterion: Criterion = "trace",
) -> tuple[FloatArray, FloatArray, float]:
    """Fuse two estimates of one state by CI; returns ``(mean, cov, λ)``.

    ``λ`` weighs estimate 1 (``λ = 1`` returns estimate 1, ``λ = 0`` estimate 2). The objective
    (``tr P`` or ``log det P``, both convex in ``λ``) is minimised by a bounded scalar search and
    compared with both endpoints; equal covariances give ``λ = 0.5``.
    """
    if criterion not in ("trace", "det"):
        raise ValueError(f"criterion must be 'trace' or 'det', got {criterion!r}")
    y1 = np.asarray(mean1, dtype=float)
    y2 = np.asarray(mean2, dtype=float)
    p1 = np.asarray(cov1, dtype=float)
    p2 = np.asarray(cov2, dtype=float)
    n = y1.shape[0]
    if y1.shape != (n,) or y2.shape != (n,) or p1.shape != (n, n) or p2.shape != (n, n):
        raise ValueError(
            f"shape mismatch: means {y1.shape}, {y2.shape}; covariances {p1.shape}, {p2.shape}"
        )

    if np.allclose(p1, p2, rtol=1e-12, atol=1e-15):
        if np.allclose(y1, y2, rtol=1e-12, atol=1e-15):
            return y1.copy(), p1.copy(), 0.5
        return 0.5 * (y1 + y2), p1.copy(), 0.5

    i1 = _inv_spd(p1)
    i2 = _inv_spd(p2)

    def objective(lam: float) -> float:
        info = lam * i1 + (1.0 - lam) * i2
        if criterion == "trace":
            return float(np.trace(_inv_spd(info)))
        sign, logdet = np.linalg.slogdet(info)
        return float(-logdet) if sign > 0 else float("inf")

    res = minimize_scalar(objective, bounds=(0.0, 1.0), method="bounded", options={"xatol": 1e-8})
    candidates = [(float(objective(0.0)), 0.0), (float(objective(1.0)), 1.0)]
    if np.isfinite(res.fun):
        candidates.append((float(res.fun), float(np.clip(res.x, 0.0, 1.0))))
    lam = min(candidates)[1]

    if lam == 1.0:
        return y1.copy(), p1.copy(), 1.0
    if lam == 0.0:
        return y2.copy(), p2.copy(), 0.0
    info = lam * i1 + (1.0 - lam) * i2
    cov = _inv_spd(info)
    mean = cov @ (lam * (i1 @ y1) + (1.0 - lam) * (i2 @ y2))
    return mean, cov, lam


def fuse_estimates(
    a: TargetEstimate, b: TargetEstimate, criterion: Criterion = "trace"
) -> tuple[TargetEstimate, FloatArray]:
    """CI fusion target by target; returns the fused estimate and the ``(N,)`` weights on ``a``."""
    if a.n_targets != b.n_targets:
        raise ValueError(f"cannot fuse estimates of {a.n_targets} and {b.n_targets} targets")
    mean = np.empty_like(a.mean)
    cov = np.empty_like(a.cov)
    lambdas = np.empty(a.n_targets)
    for j in range(a.n_targets):
        mean[j], cov[j], lambdas[j] = covariance_intersection(
            a.mean[j], a.cov[j], b.mean[j], b.cov[j], criterion
        )
    modes = _fused_modes(a, b, mean, cov, lambdas)
    return TargetEstimate(mean, cov, modes), lambdas


def _fused_modes(
    a: TargetEstimate, b: TargetEstimate, mean: FloatArray, cov: FloatArray, lambdas: FloatArray
) -> ModeStates | None:
    """The mode states of a CI fusion (docs/model.md §4): the linear pool of both estimates'
    modes with the CI weights, moved so that its moment match is the CI result. An estimate
    without modes counts as every mode at its Gaussian, with the other's probabilities."""
    if a.modes is not None and b.modes is not None:
        modes_a, modes_b = a.modes, b.modes
    elif a.modes is not None:
        modes_a, modes_b = a.modes, ModeStates.seated(b.mean, b.cov, a.modes.probabilities)
    elif b.modes is not None:
        modes_a, modes_b = ModeStates.seated(a.mean, a.cov, b.modes.probabilities), b.modes
    else:
        return None
    return pooled(modes_a, modes_b, lambdas).reseated(mean, cov)


def _inv_spd(p: FloatArray) -> FloatArray:
    """Inverse of a symmetric positive-definite matrix, symmetrised."""
    inv = np.linalg.inv(p)
    return np.asarray(0.5 * (inv + inv.T), dtype=float)
