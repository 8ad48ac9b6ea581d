"""Danger zones as they truly are, and the hazard models that fire attacks (docs/model.md §2)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from resilient_tracking.observation import ZoneClue
from resilient_tracking.scenario import CommZone, DiskHazard, GaussianHazard, SensingZone


def gaussian_pdf(x: np.ndarray, mu: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Density of ``N(mu, sigma)`` at the rows of ``x``."""
    return _pdf(x, mu, np.linalg.inv(sigma), 2 * math.pi * math.sqrt(np.linalg.det(sigma)))


def _pdf(x: np.ndarray, mu: np.ndarray, inv: np.ndarray, norm: float) -> np.ndarray:
    """:func:`gaussian_pdf` with ``Σ⁻¹`` and ``2π √det Σ`` given."""
    diff = np.atleast_2d(x) - mu
    m2 = np.einsum("ni,ij,nj->n", diff, inv, diff)
    return np.exp(-0.5 * m2) / norm


class HazardModel(Protocol):
    """Per-step attack probability of a zone for robots at ``positions``."""

    def probability(self, positions: np.ndarray, step: int, dt: float) -> np.ndarray: ...


@dataclass(frozen=True)
class GaussianHazardModel:
    """``1 − exp(−κ f_act dt pdf_N(μ,Σ)(x))``: marginalised over the unknown center."""

    mu: np.ndarray
    sigma: np.ndarray
    f_act: float
    kappa: float
    _inv: np.ndarray = field(init=False, repr=False, compare=False)
    _norm: float = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        # the density's constants, once (the world asks every step)
        object.__setattr__(self, "_inv", np.linalg.inv(self.sigma))
        object.__setattr__(self, "_norm", 2 * math.pi * math.sqrt(np.linalg.det(self.sigma)))

    def probability(self, positions: np.ndarray, step: int, dt: float) -> np.ndarray:
        density = _pdf(positions, self.mu, self._inv, self._norm)
        rate = self.kappa * self.f_act * dt * density
        return 1.0 - np.exp(-rate)


@dataclass(frozen=True)
class DiskHazardModel:
    """Inside the true disk, hit with ``p_hit`` at each activation tick (every ``1/f_act`` s)."""

    center: np.ndarray
    radius: float
    f_act: float
    p_hit: float

    def is_tick(self, step: int, dt: float) -> bool:
        eps = 1e-9
        return math.floor(step * dt * self.f_act + eps) != math.floor(
            (step - 1) * dt * self.f_act + eps
        )

    def probability(self, positions: np.ndarray, step: int, dt: float) -> np.ndarray:
        positions = np.atleast_2d(positions)
        if not self.is_tick(step, dt):
            return np.zeros(len(positions))
        inside = np.linalg.norm(positions - self.center, axis=1) <= self.radius
        return np.where(inside, self.p_hit, 0.0)


class TrueZone:
    """A zone with its true center drawn once per episode from its prior."""

    def __init__(self, zone_id: int, spec: SensingZone | CommZone, rng: np.random.Generator):
        self.id = zone_id
        self.spec = spec
        self.mu = np.asarray(spec.mu, dtype=float)
        self.sigma = np.asarray(spec.sigma, dtype=float)
        self.center = rng.multivariate_normal(self.mu, self.sigma, method="cholesky")
        self.kind = spec.kind
        self.size = spec.radius if isinstance(spec, SensingZone) else spec.delta2
        self._sigma_inv = np.linalg.inv(self.sigma)
        hazard = spec.hazard
        self.hazard: HazardModel
        if isinstance(hazard, GaussianHazard):
            self.hazard = GaussianHazardModel(self.mu, self.sigma, hazard.f_act, hazard.kappa)
        else:
            assert isinstance(hazard, DiskHazard)
            disk_radius = spec.radius if isinstance(spec, SensingZone) else self._comm_disk()
            self.hazard = DiskHazardModel(self.center, disk_radius, hazard.f_act, hazard.p_hit)

    def _comm_disk(self) -> float:
        # A comm zone has no radius; its disk hazard acts within its recovery region's scale.
        return float(self.spec.m_recover * math.sqrt(np.linalg.eigvalsh(self.sigma).max()))

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
