"""The target-motion contract and its registry (docs/model.md §1).

A target motion moves one target's truth. It is one class: ``Spec``, the pydantic model of its
parameters (a subclass of :class:`~resilient_tracking.scenario.MotionSpec`), a constructor
``Motion(spec, start)`` and :meth:`TargetMotion.step`. Register it with
``@MOTIONS.register("name")`` or an entry point of the group
``resilient_tracking.target_motions``; a scenario selects it with
``motion: {type: name, ...}`` (or ``type: package.module:Class``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

from resilient_tracking.registry import Registry
from resilient_tracking.scenario import MotionSpec


class TargetMotion(ABC):
    """One target's true position and velocity, advanced by its motion."""

    #: the pydantic model of the ``motion`` mapping this motion reads
    Spec: ClassVar[type[MotionSpec]]

    def __init__(self, spec: Any, start: np.ndarray):
        #: the motion's parameters (a ``Spec``)
        self.spec = spec
        #: true position (m)
        self.position = np.array(start, dtype=float)
        #: true velocity (m/s)
        self.velocity = np.zeros(2)

    @abstractmethod
    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Advance ``position`` and ``velocity`` by ``dt`` seconds; random draws from ``rng``
        only (the episode's ``target_motion`` stream)."""


#: Target motions by name: the built-ins, the entry points of the group
#: ``resilient_tracking.target_motions`` and dotted paths ``package.module:Class``.
MOTIONS: Registry[type[TargetMotion]] = Registry(
    "target motion",
    "resilient_tracking.target_motions",
    TargetMotion,
    builtins=("resilient_tracking.world.motions",),
)
