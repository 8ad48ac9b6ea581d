"""The estimator seam: what the team's belief asks of a target estimator.

The belief keeps one :class:`~resilient_tracking.belief.estimate.TargetEstimate` per league and
hands it to an estimator to predict it one step ahead and to update it with the league's
measurements. :class:`~resilient_tracking.belief.ekf.ExtendedKalmanFilter` is the paper's;
:class:`~resilient_tracking.belief.imm.InteractingMultipleModel` (scenario ``estimator: {type:
imm}``) is the other built-in; any object with these two verbs (for example a filter with
another motion model) can replace it.

An estimator whose noise the degradation watch can adapt (docs/model.md §6.4) says so with
``scales_noise = True`` and offers :meth:`NoiseScalingEstimator.with_update` and the keyword
``noise_scale`` of its update; one without it is used as it is, and the watch then only finds
degraded sensors.
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


class NoiseScalingEstimator(Estimator, Protocol):
    """An estimator whose measurement noise can be scaled per robot (``scales_noise = True``)."""

    #: always ``True``: what the belief reads to know the estimator offers the two below
    scales_noise: bool

    def update(  # type: ignore[override]
        self,
        est: TargetEstimate,
        robot_positions: np.ndarray,
        measurements: np.ndarray,
        noise_scale: np.ndarray | None = None,
    ) -> TargetEstimate:
        """As :meth:`Estimator.update`, robot ``k``'s noise variance times ``noise_scale[k]``
        (``None``: nominal)."""
        ...

    def with_update(self, iterations: int, second_order: bool) -> NoiseScalingEstimator:
        """The estimator whose update a league with a degraded sensor uses: ``iterations``
        linearisations, with each channel's second-order noise term or not."""
        ...
