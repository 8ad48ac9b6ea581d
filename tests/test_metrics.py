"""The per-step metrics are NumPy's numbers bit for bit, whatever the number of targets: the
MSE of the estimated positions and the position trace of an estimate."""

from __future__ import annotations

import numpy as np
import pytest

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.runs.metrics import mse


@pytest.mark.parametrize("n", [1, 2, 3, 7, 8, 20])
def test_mse_and_position_trace_are_numpys_sums(n: int) -> None:
    rng = np.random.default_rng(n)
    for _ in range(200):
        scale = 10.0 ** rng.integers(-6, 6, size=(n, 1))  # far apart: the order shows
        estimated, true = rng.normal(size=(n, 4)) * scale, rng.normal(size=(n, 4)) * scale
        error = estimated[:, :2] - true[:, :2]
        expected = np.add.reduce(np.add.reduce(error * error, axis=1)) / n
        assert mse(estimated[:, :2], true[:, :2]) == float(expected)
        root = rng.normal(size=(n, 4, 4)) * scale[:, :, None]
        estimate = TargetEstimate(estimated, root @ root.swapaxes(1, 2))
        traces = estimate.cov[:, 0, 0] + estimate.cov[:, 1, 1]
        assert estimate.position_trace() == float(np.add.reduce(traces))


def test_mse_of_positions_that_are_not_finite_is_not_finite() -> None:
    true = np.zeros((3, 2))
    estimated = np.array([[1.0, 0.0], [np.nan, 0.0], [0.0, 0.0]])
    assert np.isnan(mse(estimated, true))
    estimated[1, 0] = np.inf
    assert mse(estimated, true) == np.inf
