"""The adaptive estimator, switched on by evidence (docs/model.md §4.3).

The team tracks with the paper's EKF until the EKF's own innovations say its target model is
wrong, then with the adaptive estimator (§4.2) for the rest of the mission. The evidence is the
normalised innovation squared of every measurement the team used over the last ``window``
updates: under the EKF's model their sum is χ²-distributed with as many degrees of freedom as
measurement channels, and the switch comes when it leaves that distribution's two-sided
``1 − level`` interval — above it, the targets move more than the model allows; below it, less
(its process noise is too large, and its estimates wider than they need be). Until then every
estimate is the EKF's, bit for bit: a mission whose targets move as the model says runs as if
the adaptive estimator were absent.

The switch is one-way and team-wide (one :class:`Evidence` shared by every copy of the
estimator); estimates made before it enter the adaptive estimator with every noise level at
their Gaussian and equally likely.
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2

from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.imm import InteractingMultipleModel

log = logging.getLogger(__name__)


@dataclass
class Evidence:
    """The NIS sums and degrees of freedom of the last ``window`` updates, and whether they
    have shown the EKF's model wrong."""

    window: int
    level: float
    recent: deque[tuple[float, int]] = field(default_factory=deque)
    switched: bool = False
    #: how many updates the EKF made before the switch
    updates: int = 0

    def record(self, nis: np.ndarray, channels: int) -> bool:
        """Add one update's per-measurement NIS (NaN where none); whether the evidence now
        rejects the EKF's model (the switch, once and for good)."""
        used = nis[np.isfinite(nis)]
        self.updates += 1
        self.recent.append((float(used.sum()), int(used.size) * channels))
        while len(self.recent) > self.window:
            self.recent.popleft()
        total = sum(s for s, _ in self.recent)
        dof = sum(d for _, d in self.recent)
        if len(self.recent) == self.window and dof:
            low, high = chi2.ppf([self.level / 2, 1 - self.level / 2], dof)
            if not low <= total <= high:
                self.switched = True
        return self.switched


class AdaptiveOnEvidence:
    """The EKF until :class:`Evidence` rejects its model, then the adaptive IMM (module
    docstring). Its noise can be scaled per robot, as both estimators' can."""

    scales_noise = True

    def __init__(
        self,
        ekf: ExtendedKalmanFilter,
        adaptive: InteractingMultipleModel,
        evidence: Evidence,
    ):
        self.ekf = ekf
        self.adaptive = adaptive
        self.evidence = evidence

    @property
    def switched(self) -> bool:
        """Whether the team tracks with the adaptive estimator now."""
        return self.evidence.switched

    def predict(self, est: TargetEstimate) -> TargetEstimate:
        """The active estimator's prediction."""
        if self.evidence.switched:
            return self.adaptive.predict(est)
        return self.ekf.predict(est)

    def update(
        self,
        est: TargetEstimate,
        robot_positions: np.ndarray,
        measurements: np.ndarray,
        noise_scale: np.ndarray | None = None,
    ) -> TargetEstimate:
        """The active estimator's update; the EKF's NIS go to the evidence."""
        if self.evidence.switched:
            return self.adaptive.update(est, robot_positions, measurements, noise_scale)
        res = self.ekf.update_detailed(est, robot_positions, measurements, noise_scale)
        if self.evidence.record(res.nis, self.ekf.sensor.DIM):
            log.info(
                "the EKF's innovations reject its target model after %d updates: tracking "
                "with the adaptive estimator from now on",
                self.evidence.updates,
            )
        return res.estimate

    def with_update(self, iterations: int, second_order: bool) -> AdaptiveOnEvidence:
        """The same switch over the EKF's careful update (a league with a degraded sensor)."""
        return AdaptiveOnEvidence(
            self.ekf.with_update(iterations, second_order), self.adaptive, self.evidence
        )
