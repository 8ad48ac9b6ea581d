"""The target-motion contract and its registry (docs/model.md §1).

A target motion moves one target's truth. It is one class: ``Spec``, the pydantic model of its
parameters (a subclass of :class:`~resilient_tracking.scenario.MotionSpec`), a constructor
``Motion(spec, start)`` and :meth:`TargetMotion.step`. Register it with
``@MOTIONS.register("name")`` or an entry point of the group
``resilient_tracking.target_motions``; a scenario selects it with
``motion: {type: name, ...}`` (or ``type: package.module:Class``).

A motion that reacts to the world sets ``reacts = True`` (and so does its ``Spec``, so that a
scenario is checked without the world): before every step the world hands it
the truth around it, a :class:`Surroundings`, through :meth:`TargetMotion.sense`. Motions that
do not react are never handed anything.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from resilient_tracking.registry import Registry
from resilient_tracking.scenario import MotionSpec


@dataclass(frozen=True)
class ZoneTruth:
    """One danger zone as it truly is, as a target that knows it sees it."""

    #: the zone's ``name`` in the scenario (``None`` when it has none)
    name: str | None
    #: ``sensing`` or ``comm``
    kind: str
    #: the true centre drawn for the episode (m)
    center: np.ndarray
    #: the prior mean μ and covariance Σ of the centre
    mu: np.ndarray
    sigma: np.ndarray
    #: the size an attack clue reports: a sensing zone's radius r (m), a comm zone's δ2
    size: float
    #: radius (m) of the zone's hazard disk around ``center``: a sensing zone's r; a comm
    #: zone's recovery scale ``m_recover · √λmax(Σ)`` (the disk hazard model's radius)
    radius: float


@dataclass(frozen=True)
class Surroundings:
    """The truth a reacting target motion sees before a step: simulator truth, never shown to
    the robots."""

    #: simulated time (s) at the start of the step
    time: float
    #: ``(M, 2)`` true robot positions (m), after the robots' move of this step
    robots: np.ndarray
    #: the danger zones, in scenario order
    zones: tuple[ZoneTruth, ...]
    #: the workspace's lower ``[xmin, ymin]`` and upper ``[xmax, ymax]`` corners (m)
    lower: np.ndarray
    upper: np.ndarray

    def zone(self, name: str) -> ZoneTruth | None:
        """The zone called ``name``, else ``None``."""
        return next((z for z in self.zones if z.name == name), None)


class TargetMotion(ABC):
    """One target's true position and velocity, advanced by its motion."""

    #: the pydantic model of the ``motion`` mapping this motion reads
    Spec: ClassVar[type[MotionSpec]]
    #: whether the world calls :meth:`sense` before each step (a motion that reacts to robots
    #: or zones); ``False``: the motion is scripted and never sees the world
    reacts: ClassVar[bool] = False

    def __init__(self, spec: Any, start: np.ndarray):
        #: the motion's parameters (a ``Spec``)
        self.spec = spec
        #: true position (m)
        self.position = np.array(start, dtype=float)
        #: true velocity (m/s)
        self.velocity = np.zeros(2)

    def sense(self, surroundings: Surroundings) -> None:  # noqa: B027 (optional hook)
        """Take in the world's truth before the next :meth:`step`; called only when
        ``reacts`` is set. Does nothing by default."""

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
    builtins=(
        "resilient_tracking.world.motions",
        "resilient_tracking.world.evasive",
        "resilient_tracking.world.lure",
    ),
)
