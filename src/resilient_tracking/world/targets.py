"""Scripted truth motion of the targets (docs/model.md §1).

Each target's motion is found by its ``type`` in
:data:`~resilient_tracking.world.target_motion.MOTIONS`; the built-ins are in
:mod:`resilient_tracking.world.motions`.
"""

from __future__ import annotations

import numpy as np

from resilient_tracking.scenario import TargetSpec
from resilient_tracking.world.target_motion import MOTIONS, Surroundings, TargetMotion


class TargetTruth:
    """One target's true position and velocity, advanced by its scripted motion."""

    def __init__(self, spec: TargetSpec):
        self.spec = spec
        start = np.asarray(spec.start, dtype=float)
        self.motion: TargetMotion = MOTIONS.get(spec.motion.type)(spec.motion, start)

    @property
    def position(self) -> np.ndarray:
        """True position (m)."""
        return self.motion.position

    @position.setter
    def position(self, value: np.ndarray) -> None:
        self.motion.position = value

    @property
    def velocity(self) -> np.ndarray:
        """True velocity (m/s)."""
        return self.motion.velocity

    @velocity.setter
    def velocity(self, value: np.ndarray) -> None:
        self.motion.velocity = value

    @property
    def state(self) -> np.ndarray:
        """``[px, py, vx, vy]``."""
        return np.concatenate([self.position, self.velocity])

    @property
    def reacts(self) -> bool:
        """Whether the motion reacts to the world (it is handed :class:`Surroundings`)."""
        return self.motion.reacts

    def sense(self, surroundings: Surroundings) -> None:
        """Hand a reacting motion the truth around it before the next step."""
        self.motion.sense(surroundings)

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Advance the truth by ``dt`` seconds."""
        self.motion.step(dt, rng)
