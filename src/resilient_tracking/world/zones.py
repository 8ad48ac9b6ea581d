"""Danger zones as they truly are (docs/model.md §2); their hazard models fire the attacks.

The hazard model of a zone is found by name in
:data:`~resilient_tracking.world.hazard_model.HAZARDS`; the built-ins are in
:mod:`resilient_tracking.world.hazards`.
"""

from __future__ import annotations

import numpy as np

from resilient_tracking.observation import ZoneClue
from resilient_tracking.scenario import CommZone, SensingZone
from resilient_tracking.world.hazard_model import HAZARDS, HazardModel
from resilient_tracking.world.hazards import DiskHazardModel, GaussianHazardModel, gaussian_pdf

__all__ = [
    "DiskHazardModel",
    "GaussianHazardModel",
    "HazardModel",
    "TrueZone",
    "gaussian_pdf",
]


class TrueZone:
    """A zone with its true center drawn once per episode from its prior."""

    def __init__(self, zone_id: int, spec: SensingZone | CommZone, rng: np.random.Generator):
        self.id = zone_id
        self.spec = spec
        self.mu = np.asarray(spec.mu, dtype=float)
        self.sigma = np.asarray(spec.sigma, dtype=float)
        self.center = rng.multivariate_normal(self.mu, self.sigma, method="cholesky")
        self.kind = spec.kind
        self.size = spec.size
        self._sigma_inv = np.linalg.inv(self.sigma)
        self.hazard: HazardModel = HAZARDS.get(spec.hazard.model).from_zone(spec.hazard, self)

    def in_influence(self, position: np.ndarray) -> bool:
        """Inside the Mahalanobis ball ``(x−μ)ᵀΣ⁻¹(x−μ) ≤ m_recover²`` (temporary failures)."""
        d = position - self.mu
        return float(d @ self._sigma_inv @ d) <= self.spec.m_recover**2

    def clue(self) -> ZoneClue:
        """The prior a victim learns on attack."""
        return ZoneClue(
            zone_id=self.id,
            kind=self.kind,
            mu=self.mu.copy(),
            sigma=self.sigma.copy(),
            size=float(self.size),
            persistence=self.spec.persistence,
        )
