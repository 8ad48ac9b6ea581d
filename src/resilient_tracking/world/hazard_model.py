"""The hazard-model contract and its registry (docs/model.md §2).

A hazard model turns a zone's ``hazard`` mapping into per-step attack probabilities. It is one
class: ``Spec``, the pydantic model of its parameters (a subclass of
:class:`~resilient_tracking.scenario.HazardSpec`), :meth:`HazardModel.from_zone` to build it for
a zone with its true center drawn, and :meth:`HazardModel.probability`. Register it with
``@HAZARDS.register("name")`` or an entry point of the group ``resilient_tracking.hazards``; a
scenario selects it with ``hazard: {model: name, ...}`` (or ``model: package.module:Class``).

A zone with a ``motion`` moves its ``mu`` and ``center`` arrays in place each step: a model that
keeps those arrays (as the built-ins do) moves with the zone; one that copies them stays put.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar, Protocol

import numpy as np

from resilient_tracking.registry import Registry
from resilient_tracking.scenario import CommZone, HazardSpec, SensingZone


class HazardZone(Protocol):
    """What a hazard model is built from: a zone as it truly is in the episode
    (:class:`~resilient_tracking.world.zones.TrueZone`)."""

    #: prior mean and covariance of the zone's centre
    mu: np.ndarray
    sigma: np.ndarray
    #: the centre drawn for the episode
    center: np.ndarray
    #: the zone's scenario section
    spec: SensingZone | CommZone


class HazardModel(ABC):
    """Per-step attack probability of one zone for robots at given positions."""

    #: the pydantic model of the ``hazard`` mapping this model reads
    Spec: ClassVar[type[HazardSpec]]

    @classmethod
    def from_zone(cls, spec: Any, zone: HazardZone) -> HazardModel:
        """The model for ``zone`` (its prior ``mu``, ``sigma``, true ``center`` and scenario
        ``spec``) with the parameters ``spec`` (a ``Spec``)."""
        raise NotImplementedError(f"{cls.__name__} must define from_zone")

    @abstractmethod
    def probability(self, positions: np.ndarray, step: int, dt: float) -> np.ndarray:
        """``(n,)`` probabilities that robots at ``positions`` ``(n, 2)`` are attacked at
        ``step`` (each tick lasts ``dt`` seconds)."""


#: Hazard models by name: the built-ins (gaussian, disk), the entry points of the group
#: ``resilient_tracking.hazards`` and dotted paths ``package.module:Class``.
HAZARDS: Registry[type[HazardModel]] = Registry(
    "hazard model",
    "resilient_tracking.hazards",
    HazardModel,
    builtins=("resilient_tracking.world.hazards",),
)
