"""Per-step metrics of docs/model.md §8: MSE, covariance trace, control effort."""

from __future__ import annotations

import numpy as np

from resilient_tracking.models.geometry import row_norms


def mse(estimated_positions: np.ndarray, true_positions: np.ndarray) -> float:
    """``(1/N) Σ_j ‖ŷ_j − y_j‖²`` over target positions (N, 2)."""
    error = estimated_positions - true_positions
    # (x ** 2 is x * x, through a slower dispatch; np.add.reduce is what ndarray.sum calls,
    # without its Python wrapper)
    squared = np.add.reduce(error * error, axis=1)
    return float(np.add.reduce(squared) / len(squared))  # np.mean's sum and division


def effort(controls: np.ndarray) -> float:
    """``Σ_i ‖u_i‖`` of the applied velocities (M, 2)."""
    return float(row_norms(controls).sum())
