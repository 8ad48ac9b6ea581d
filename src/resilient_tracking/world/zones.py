"""Danger zones as they truly are (docs/model.md §2); their hazard models fire the attacks.

The hazard model of a zone is found by name in
:data:`~resilient_tracking.world.hazard_model.HAZARDS`; the built-ins are in
:mod:`resilient_tracking.world.hazards`.
"""

from __future__ import annotations

from typing import cast

import numpy as np

from resilient_tracking.observation import FailureKind, ZoneClue
from resilient_tracking.scenario import CommZone, SensingZone
from resilient_tracking.world.hazard_model import HAZARDS, HazardModel
from resilient_tracking.world.hazards import DiskHazardModel, GaussianHazardModel, gaussian_pdf
from resilient_tracking.world.target_motion import MOTIONS, TargetMotion

__all__ = [
    "DiskHazardModel",
    "GaussianHazardModel",
    "HazardModel",
    "TrueZone",
    "gaussian_pdf",
]


class TrueZone:
    """A zone with its true center drawn once per episode from its prior.

    A zone with a ``motion`` moves (docs/model.md §2): the motion starts at the prior mean, and
    after each step both the prior mean ``mu`` and the drawn ``center`` are shifted by the
    motion's displacement from its start, so the centre keeps its drawn offset from the mean.
    The arrays are updated in place: a hazard model built over them moves with the zone.
    """

    def __init__(self, zone_id: int, spec: SensingZone | CommZone, rng: np.random.Generator):
        self.id = zone_id
        self.spec = spec
        self.mu = np.asarray(spec.mu, dtype=float)
        self.sigma = np.asarray(spec.sigma, dtype=float)
        self.center = rng.multivariate_normal(self.mu, self.sigma, method="cholesky")
        #: the capabilities an attack disables, and what a clue reports as the size of each
        self.kinds = cast(tuple[FailureKind, ...], spec.kinds)
        self.sizes = spec.sizes
        #: ``sensing``, ``comm``, or ``sensing+comm`` for a zone that attacks both
        self.kind = "+".join(self.kinds)
        #: the size of the zone's first kind (a multimodal zone's radius ``r``)
        self.size = self.sizes[self.kinds[0]]
        self._sigma_inv = np.linalg.inv(self.sigma)
        self.hazard: HazardModel = HAZARDS.get(spec.hazard.model).from_zone(spec.hazard, self)
        self.motion: TargetMotion | None = None
        if spec.motion is not None:
            self.motion = MOTIONS.get(spec.motion.type)(spec.motion, self.mu)
            if self.motion.reacts:  # a plug-in whose spec did not say so
                raise ValueError(
                    f"zones.{zone_id}.motion.type: a zone's motion must not react to the world "
                    f"(got {spec.motion.type!r})"
                )
            self._start, self._drawn = self.mu.copy(), self.center.copy()
        #: a moving zone's truth over time: ``(step, mu_x, mu_y, true_x, true_y)`` per step
        self.track: list[tuple[int, float, float, float, float]] = []
        if self.motion is not None:
            self._record(0)

    @property
    def moves(self) -> bool:
        """Whether the zone has a motion."""
        return self.motion is not None

    def move(self, dt: float, rng: np.random.Generator, step: int) -> None:
        """Advance the zone's motion by ``dt`` seconds (draws, if any, from ``rng``) to
        ``step``, and shift the prior mean and the true centre by its displacement; a static
        zone stays."""
        if self.motion is None:
            return
        self.motion.step(dt, rng)
        offset = self.motion.position - self._start
        self.mu[:] = self._start + offset
        self.center[:] = self._drawn + offset
        self._record(step)

    def _record(self, step: int) -> None:
        mu, center = self.mu.tolist(), self.center.tolist()
        self.track.append((step, mu[0], mu[1], center[0], center[1]))

    def in_influence(self, position: np.ndarray) -> bool:
        """Inside the Mahalanobis ball ``(x−μ)ᵀΣ⁻¹(x−μ) ≤ m_recover²`` (temporary failures)."""
        d = position - self.mu
        return float(d @ self._sigma_inv @ d) <= self.spec.m_recover**2

    def clue(self, kind: FailureKind | None = None) -> ZoneClue:
        """The prior a victim learns on an attack disabling ``kind`` (the zone's first kind by
        default): a snapshot of the prior as it is now, never the zone's motion. A zone of
        several kinds lists them all with their sizes (``modes``)."""
        kind = kind or self.kinds[0]
        return ZoneClue(
            zone_id=self.id,
            kind=kind,
            mu=self.mu.copy(),
            sigma=self.sigma.copy(),
            size=float(self.sizes[kind]),
            persistence=self.spec.persistence,
            modes=tuple((k, float(self.sizes[k])) for k in self.kinds)
            if len(self.kinds) > 1
            else (),
        )
