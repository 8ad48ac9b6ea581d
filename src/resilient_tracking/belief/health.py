"""Numerical health of covariance matrices: check, and repair with a report (docs/reliability.md).

The EKF (Joseph form, symmetrised) and covariance intersection keep covariances symmetric
positive definite in exact arithmetic; in floating point a long run can still drift. Each tick
the team belief passes its league estimates through :func:`repair_covariances`, which

* symmetrises every matrix (``(P + Pᵀ)/2``),
* floors its eigenvalues at ``EIGEN_FLOOR_RATIO · λmax`` (and at ``EIGEN_FLOOR_ABS``), and
* replaces a matrix that is not finite at all by ``fallback`` (the prior's spread),

and reports each matrix it had to change, so the caller can log an event.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from resilient_tracking.models.numpy_twins import all_finite

FloatArray = NDArray[np.float64]

#: Relative asymmetry ``max|P − Pᵀ| / max|P|`` tolerated without a report (rounding level).
ASYMMETRY_TOL = 1e-9
#: Smallest eigenvalue allowed, relative to the largest one.
EIGEN_FLOOR_RATIO = 1e-12
#: Smallest eigenvalue allowed, absolute (state units squared).
EIGEN_FLOOR_ABS = 1e-12


@dataclass(frozen=True)
class Repair:
    """One matrix that was changed: its index, what was wrong, and how badly."""

    index: int
    problem: str  # "asymmetric", "not positive definite", "not finite"
    asymmetry: float
    min_eigenvalue: float

    def describe(self) -> str:
        """One line for the log: the target, what was wrong, the asymmetry and the smallest
        eigenvalue."""
        return (
            f"target {self.index}: {self.problem} "
            f"(asymmetry {self.asymmetry:.3g}, min eigenvalue {self.min_eigenvalue:.3g})"
        )


def repair_covariances(
    cov: FloatArray, fallback: FloatArray | None = None
) -> tuple[FloatArray, list[Repair]]:
    """Symmetric positive-definite copies of a stack ``(N, d, d)``; lists what was repaired.

    Matrices that are already healthy come back symmetrised but otherwise unchanged.
    ``fallback`` ``(d, d)`` replaces a matrix with a non-finite entry (default: identity).
    """
    cov = np.array(cov, dtype=float, copy=True)
    healthy = _surely_healthy(cov)  # may be this copy itself
    if healthy is not None:
        return healthy, []
    n, d = cov.shape[0], cov.shape[-1]
    repairs: list[Repair] = []
    finite = np.all(np.isfinite(cov), axis=(1, 2))
    for bad in np.flatnonzero(~finite).tolist():
        cov[bad] = np.eye(d) if fallback is None else fallback
        repairs.append(Repair(bad, "not finite", float("nan"), float("nan")))
    scale = np.maximum(np.abs(cov).max(axis=(1, 2)), np.finfo(float).tiny)
    asym = np.abs(cov - np.swapaxes(cov, 1, 2)).max(axis=(1, 2)) / scale
    cov = 0.5 * (cov + np.swapaxes(cov, 1, 2))
    eig, vec = np.linalg.eigh(cov)
    floor = np.maximum(EIGEN_FLOOR_RATIO * eig[:, -1:], EIGEN_FLOOR_ABS)
    low = np.any(eig < floor, axis=1)
    for j in range(n):
        if not finite[j]:
            continue
        if low[j]:
            clipped = np.maximum(eig[j], floor[j])
            cov[j] = (vec[j] * clipped) @ vec[j].T
            cov[j] = 0.5 * (cov[j] + cov[j].T)
            repairs.append(Repair(j, "not positive definite", float(asym[j]), float(eig[j, 0])))
        elif asym[j] > ASYMMETRY_TOL:
            repairs.append(Repair(j, "asymmetric", float(asym[j]), float(eig[j, 0])))
    repairs.sort(key=lambda r: r.index)
    return cov, repairs


def surely_healthy(cov: FloatArray) -> bool:
    """Whether :func:`repair_covariances` would surely report nothing for the stack ``cov``
    ``(N, d, d)`` (decided cheaply, without copying it); ``False``: it may have to repair."""
    return _surely_healthy(np.asarray(cov, dtype=float)) is not None


def _surely_healthy(cov: FloatArray) -> FloatArray | None:
    """The symmetrised stack if every matrix is finite, symmetric to ``ASYMMETRY_TOL`` and
    has all eigenvalues above twice the floor, else None. The common case, decided without an
    eigen-decomposition; :func:`repair_covariances` gives the same answer (no repair) for it.
    An exactly symmetric stack, as the filter leaves it, comes back as itself: ``(P + Pᵀ)/2``
    would be ``P``.

    The eigenvalues: a Cholesky factorisation of every ``P − t I`` exists, with one shift for
    the stack, ``t = 2 max(EIGEN_FLOOR_RATIO Σ tr P, EIGEN_FLOOR_ABS)``. Where it exists,
    every diagonal entry is above ``t > 0``, so the stack's total trace ``Σ tr P`` bounds each
    matrix's ``λmax ≤ tr P``, and ``t`` is at least twice each matrix's floor (a stack of very
    unequal matrices may fail where each alone would pass: the eigen path then decides)."""
    if not all_finite(cov):
        return None
    transposed = cov.swapaxes(1, 2)
    # the same bytes (as the filter leaves it) is symmetric; else compare the numbers (±0)
    if cov.tobytes() == transposed.tobytes() or np.count_nonzero(cov != transposed) == 0:
        sym = cov
    else:
        scale = np.maximum(np.abs(cov).max(axis=(1, 2)), np.finfo(float).tiny)
        if np.any(np.abs(cov - transposed).max(axis=(1, 2)) / scale > ASYMMETRY_TOL):
            return None
        sym = 0.5 * (cov + transposed)
    total_trace = float(np.add.reduce(sym.diagonal(0, 1, 2), axis=None))
    shift = 2.0 * max(EIGEN_FLOOR_RATIO * total_trace, EIGEN_FLOOR_ABS)
    if not math.isfinite(shift):  # a stack too large to shift: the eigen path decides
        return None
    try:
        np.linalg.cholesky(sym - shift * _eye(cov.shape[-1]))
    except np.linalg.LinAlgError:
        return None
    return sym


@functools.cache
def _eye(d: int) -> FloatArray:
    eye = np.eye(d)
    eye.flags.writeable = False
    return eye


def is_spd(cov: FloatArray) -> bool:
    """Whether every matrix of a stack is finite, symmetric and has eigenvalues ≥ the floor."""
    cov = np.asarray(cov, dtype=float)
    if not np.all(np.isfinite(cov)):
        return False
    if np.any(cov != np.swapaxes(cov, -1, -2)):
        return False
    eig = np.linalg.eigvalsh(cov)
    floor = np.maximum(EIGEN_FLOOR_RATIO * eig[..., -1:], EIGEN_FLOOR_ABS)
    return bool(np.all(eig >= 0.5 * floor))  # half: eigenvalue rounding at the floor itself
