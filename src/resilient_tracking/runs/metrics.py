"""Per-step metrics of docs/model.md §8: MSE, the Gaussian NLL and NEES of the truth under the
team's estimate, covariance trace, control effort; and the χ² band of a run's ANEES.

MSE and trace are the paper's. NLL and NEES judge an estimate against truth with its own
covariance: the NEES ``eᵀ P⁻¹ e`` (position error ``e``, position covariance ``P``) says
whether the covariance is honest (its mean is 2, the position's dimension, for a consistent
filter); the NLL ``½ (eᵀ P⁻¹ e + ln det(2π P))`` is a proper scoring rule, lowest in
expectation for the estimate whose Gaussian is the truth's distribution, so neither a
confident wrong estimate nor a timid right one can win on it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.stats import chi2

from resilient_tracking.models.geometry import row_norms

#: Dimension of the scored state: a target's position.
POSITION_DIM = 2
_LOG_2PI = math.log(2.0 * math.pi)


def mse(estimated_positions: np.ndarray, true_positions: np.ndarray) -> float:
    """``(1/N) Σ_j ‖ŷ_j − y_j‖²`` over target positions (N, 2)."""
    error = estimated_positions - true_positions
    # (x ** 2 is x * x, through a slower dispatch; np.add.reduce is what ndarray.sum calls,
    # without its Python wrapper)
    squared = np.add.reduce(error * error, axis=1)
    return float(np.add.reduce(squared) / len(squared))  # np.mean's sum and division


def position_nees(error: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Per target ``eᵀ P⁻¹ e`` of position errors ``error`` (N, 2) under covariances ``cov``
    (N, 2, 2), by the 2×2 inverse in closed form."""
    a, b, c = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
    ex, ey = error[:, 0], error[:, 1]
    return np.asarray((c * ex * ex - 2.0 * b * ex * ey + a * ey * ey) / (a * c - b * b))


def position_nll(error: np.ndarray, cov: np.ndarray, nees: np.ndarray | None = None) -> np.ndarray:
    """Per target the Gaussian negative log-likelihood (nats) of the true position:
    ``½ (eᵀ P⁻¹ e + ln det P) + ln 2π`` for ``error`` (N, 2) and ``cov`` (N, 2, 2) (``nees``:
    their :func:`position_nees`, when already at hand)."""
    det = cov[:, 0, 0] * cov[:, 1, 1] - cov[:, 0, 1] * cov[:, 1, 0]
    nees = position_nees(error, cov) if nees is None else nees
    return np.asarray(0.5 * (nees + np.log(det)) + _LOG_2PI)


def step_scores(
    estimated_positions: np.ndarray, true_positions: np.ndarray, cov: np.ndarray
) -> tuple[float, float]:
    """The step's mean NLL and mean NEES over targets (positions (N, 2), position covariances
    (N, 2, 2))."""
    error = estimated_positions - true_positions
    nees = position_nees(error, cov)
    return float(position_nll(error, cov, nees).mean()), float(nees.mean())


def anees_band(samples: int, level: float = 0.95, dim: int = POSITION_DIM) -> tuple[float, float]:
    """The two-sided ``level`` band of the average of ``samples`` NEES values of a consistent
    filter, each χ² with ``dim`` degrees of freedom: ``χ²(dim·samples)`` quantiles ÷ ``samples``.

    It takes the samples as independent; a filter's errors are correlated from step to step,
    so a run's ANEES spreads wider than this band even when the filter is consistent
    (docs/model.md §8 says how to read it)."""
    if samples < 1:
        raise ValueError(f"anees_band needs at least one sample, got {samples}")
    tail = (1.0 - level) / 2.0
    dof = dim * samples
    return float(chi2.ppf(tail, dof) / samples), float(chi2.ppf(1.0 - tail, dof) / samples)


def effort(controls: np.ndarray) -> float:
    """``Σ_i ‖u_i‖`` of the applied velocities (M, 2)."""
    return float(row_norms(controls).sum())
