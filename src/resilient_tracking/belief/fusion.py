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

from resilient_tracking.belief.ci_search import bounded_minimize
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.modes import ModeStates, pooled

FloatArray = NDArray[np.float64]
Criterion = Literal["trace", "det"]
#: the bounded search's tolerance on ``λ``
XATOL = 1e-8


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
    pair = _Pair.of(mean1, cov1, mean2, cov2, criterion)
    return pair.shortcut if pair.shortcut is not None else pair.fused(pair.weight())


def fuse_estimates(
    a: TargetEstimate, b: TargetEstimate, criterion: Criterion = "trace"
) -> tuple[TargetEstimate, FloatArray]:
    """CI fusion target by target; returns the fused estimate and the ``(N,)`` weights on ``a``.

    With the trace criterion every target's search runs side by side
    (:func:`~.ci_search.bounded_minimize`, the same numbers as one search per target)."""
    if a.n_targets != b.n_targets:
        raise ValueError(f"cannot fuse estimates of {a.n_targets} and {b.n_targets} targets")
    mean = np.empty_like(a.mean)
    cov = np.empty_like(a.cov)
    lambdas = np.empty(a.n_targets)
    pairs = [
        _Pair.of(a.mean[j], a.cov[j], b.mean[j], b.cov[j], criterion) for j in range(a.n_targets)
    ]
    searched = [j for j, pair in enumerate(pairs) if pair.shortcut is None]
    if criterion == "trace" and searched:
        weights = _searched_weights([pairs[j] for j in searched])
    else:
        weights = [pairs[j].weight() for j in searched]
    for j, pair in enumerate(pairs):
        if pair.shortcut is not None:
            mean[j], cov[j], lambdas[j] = pair.shortcut
    for j, lam in zip(searched, weights, strict=True):
        mean[j], cov[j], lambdas[j] = pairs[j].fused(lam)
    modes = _fused_modes(a, b, mean, cov, lambdas)
    return TargetEstimate(mean, cov, modes), lambdas


class _Pair:
    """Two estimates of one state to fuse, checked, with their information matrices."""

    def __init__(
        self, inputs: tuple[FloatArray, FloatArray, FloatArray, FloatArray], crit: Criterion
    ):
        self.inputs = inputs
        y1, p1, y2, p2 = inputs
        self.criterion = crit
        self.shortcut: tuple[FloatArray, FloatArray, float] | None = None
        if np.allclose(p1, p2, rtol=1e-12, atol=1e-15):
            if np.allclose(y1, y2, rtol=1e-12, atol=1e-15):
                self.shortcut = y1.copy(), p1.copy(), 0.5
            else:
                self.shortcut = 0.5 * (y1 + y2), p1.copy(), 0.5
            return
        self.i1 = _inv_spd(p1)
        self.i2 = _inv_spd(p2)

    @classmethod
    def of(
        cls,
        mean1: FloatArray,
        cov1: FloatArray,
        mean2: FloatArray,
        cov2: FloatArray,
        criterion: Criterion,
    ) -> _Pair:
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
        return cls((y1, p1, y2, p2), criterion)

    def objective(self, lam: float) -> float:
        info = lam * self.i1 + (1.0 - lam) * self.i2
        if self.criterion == "trace":
            return float(np.trace(_inv_spd(info)))
        sign, logdet = np.linalg.slogdet(info)
        return float(-logdet) if sign > 0 else float("inf")

    def weight(self) -> float:
        """``λ`` by one bounded search, against both endpoints."""
        res = minimize_scalar(
            self.objective, bounds=(0.0, 1.0), method="bounded", options={"xatol": XATOL}
        )
        ends = (self.objective(0.0), self.objective(1.0))
        return _weight(ends, float(res.fun), float(res.x))

    def fused(self, lam: float) -> tuple[FloatArray, FloatArray, float]:
        y1, p1, y2, p2 = self.inputs
        if lam == 1.0:
            return y1.copy(), p1.copy(), 1.0
        if lam == 0.0:
            return y2.copy(), p2.copy(), 0.0
        info = lam * self.i1 + (1.0 - lam) * self.i2
        cov = _inv_spd(info)
        mean = cov @ (lam * (self.i1 @ y1) + (1.0 - lam) * (self.i2 @ y2))
        return mean, cov, lam


def _weight(ends: tuple[float, float], found: float, at: float) -> float:
    """The best of both endpoints and the search's minimum (the smaller ``λ`` on a tie)."""
    candidates = [(ends[0], 0.0), (ends[1], 1.0)]
    if np.isfinite(found):
        candidates.append((found, float(np.clip(at, 0.0, 1.0))))
    return min(candidates)[1]


def _searched_weights(pairs: list[_Pair]) -> list[float]:
    """The trace-criterion weights of ``pairs``, their searches side by side."""
    i1 = np.stack([pair.i1 for pair in pairs])
    i2 = np.stack([pair.i2 for pair in pairs])

    def traces(lam: FloatArray, rows: NDArray[np.bool_]) -> FloatArray:
        info = lam[:, None, None] * i1[rows] + (1.0 - lam)[:, None, None] * i2[rows]
        inv = np.linalg.inv(info)
        return np.asarray(np.trace(0.5 * (inv + np.swapaxes(inv, 1, 2)), axis1=1, axis2=2))

    every = np.ones(len(pairs), dtype=bool)
    at, found = bounded_minimize(traces, len(pairs), xatol=XATOL)
    low, high = traces(np.zeros(len(pairs)), every), traces(np.ones(len(pairs)), every)
    return [
        _weight((float(low[k]), float(high[k])), float(found[k]), float(at[k]))
        for k in range(len(pairs))
    ]


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
