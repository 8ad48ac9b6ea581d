"""Per-step metrics of docs/model.md §8: MSE, covariance trace, control effort."""

from __future__ import annotations

import numpy as np

from resilient_tracking.models.geometry import row_norms
from resilient_tracking.models.numpy_direct import IN_ORDER, sum_in_order


def mse(estimated_positions: np.ndarray, true_positions: np.ndarray) -> float:
    """``(1/N) Σ_j ‖ŷ_j − y_j‖²`` over target positions (N, 2)."""
    n = len(estimated_positions)
    if (
        0 < n <= IN_ORDER
        and estimated_positions.dtype == true_positions.dtype == np.float64
        and estimated_positions.shape == true_positions.shape == (n, 2)
    ):  # a few targets: the same operations in Python floats, in NumPy's order
        squared_floats = [
            (ex - tx) * (ex - tx) + (ey - ty) * (ey - ty)
            for (ex, ey), (tx, ty) in zip(
                estimated_positions.tolist(), true_positions.tolist(), strict=True
            )
        ]
        return sum_in_order(squared_floats) / n
    error = estimated_positions - true_positions
    # (x ** 2 is x * x, through a slower dispatch; np.add.reduce is what ndarray.sum calls,
    # without its Python wrapper)
    squared = np.add.reduce(error * error, axis=1)
    return float(np.add.reduce(squared) / len(squared))  # np.mean's sum and division


def effort(controls: np.ndarray) -> float:
    """``Σ_i ‖u_i‖`` of the applied velocities (M, 2)."""
    return float(row_norms(controls).sum())
