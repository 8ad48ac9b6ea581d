"""The built-in hazard models (docs/model.md §2): ``gaussian`` and ``disk``."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from resilient_tracking.scenario import DiskHazard, GaussianHazard, SensingZone
from resilient_tracking.world.hazard_model import HAZARDS, HazardModel, HazardZone


def gaussian_pdf(x: np.ndarray, mu: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Density of ``N(mu, sigma)`` at the rows of ``x``."""
    inv, norm = np.linalg.inv(sigma), 2 * math.pi * math.sqrt(np.linalg.det(sigma))
    return _pdf(np.atleast_2d(x), mu, inv, norm)


def _pdf(x: np.ndarray, mu: np.ndarray, inv: np.ndarray, norm: float) -> np.ndarray:
    """:func:`gaussian_pdf` with ``Σ⁻¹`` and ``2π √det Σ`` given, at the rows of ``x`` (2-D)."""
    diff = x - mu
    m2 = np.einsum("ni,ij,nj->n", diff, inv, diff)
    # (ufuncs called by name: faster than the operators with a Python float, same numbers)
    return np.divide(np.exp(np.multiply(-0.5, m2)), norm)


@HAZARDS.register("gaussian")
@dataclass(frozen=True)
class GaussianHazardModel(HazardModel):
    """``1 − exp(−κ f_act dt pdf_N(μ,Σ)(x))``: marginalised over the unknown center."""

    Spec = GaussianHazard

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

    @classmethod
    def from_zone(cls, spec: GaussianHazard, zone: HazardZone) -> GaussianHazardModel:
        """The model over the zone's prior ``N(μ, Σ)``."""
        return cls(zone.mu, zone.sigma, spec.f_act, spec.kappa)

    def probability(self, positions: np.ndarray, step: int, dt: float) -> np.ndarray:
        """Attack probability at each position (the same at every step)."""
        density = _pdf(positions, self.mu, self._inv, self._norm)
        # −(κ f dt · pdf) as (−κ f dt) · pdf: negating is exact, so the same numbers, one call less
        minus_rate = np.multiply(-(self.kappa * self.f_act * dt), density)
        return np.subtract(1.0, np.exp(minus_rate))


@HAZARDS.register("disk")
@dataclass(frozen=True)
class DiskHazardModel(HazardModel):
    """Inside the true disk, hit with ``p_hit`` at each activation tick (every ``1/f_act`` s)."""

    Spec = DiskHazard

    center: np.ndarray
    radius: float
    f_act: float
    p_hit: float

    @classmethod
    def from_zone(cls, spec: DiskHazard, zone: HazardZone) -> DiskHazardModel:
        """The disk around the true center: a sensing zone's radius; a comm zone, which has
        none, acts within its recovery region's scale ``m_recover · √λmax(Σ)``."""
        if isinstance(zone.spec, SensingZone):
            radius = zone.spec.radius
        else:
            radius = float(zone.spec.m_recover * math.sqrt(np.linalg.eigvalsh(zone.sigma).max()))
        return cls(zone.center, radius, spec.f_act, spec.p_hit)

    def is_tick(self, step: int, dt: float) -> bool:
        """Whether ``step`` is an activation tick of the zone."""
        eps = 1e-9
        return math.floor(step * dt * self.f_act + eps) != math.floor(
            (step - 1) * dt * self.f_act + eps
        )

    def probability(self, positions: np.ndarray, step: int, dt: float) -> np.ndarray:
        """``p_hit`` inside the disk at an activation tick, else 0."""
        positions = np.atleast_2d(positions)
        if not self.is_tick(step, dt):
            return np.zeros(len(positions))
        inside = np.linalg.norm(positions - self.center, axis=1) <= self.radius
        return np.where(inside, self.p_hit, 0.0)
