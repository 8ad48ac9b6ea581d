"""The estimator seam: what the team's belief asks of a target estimator.

The belief keeps one :class:`~resilient_tracking.belief.estimate.TargetEstimate` per league and
hands it to an estimator to predict it one step ahead and to update it with the league's
measurements. :class:`~resilient_tracking.belief.ekf.ExtendedKalmanFilter` is the paper's;
:class:`~resilient_tracking.belief.imm.InteractingMultipleModel` (scenario ``estimator: {type:
imm}``) is the other built-in; any object with these two verbs (for example a filter with
another motion model) can replace it.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from resilient_tracking.belief.estimate import TargetEstimate


class Estimator(Protocol):
    """Predicts and updates the estimates of ``N`` targets (values: returns new objects)."""

    def predict(self, est: TargetEstimate) -> TargetEstimate:
        """The estimate one time step later."""
        ...

    def update(
        self, est: TargetEstimate, robot_positions: np.ndarray, measurements: np.ndarray
    ) -> TargetEstimate:
        """The estimate after the measurements of ``K`` robots at ``robot_positions`` (NaN where a
        robot did not measure a target)."""
        ...
