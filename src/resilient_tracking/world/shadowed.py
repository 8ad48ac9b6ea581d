"""A target motion that wraps a base motion and runs it on as a shadow (``evasive``, ``lure``).

The base motion keeps stepping from the same random stream as a plain target of that motion,
so its position is where the target would have been. While the wrapper is ``on_base`` the
target follows it exactly; after a detour it steers back to the shadow
(:func:`~resilient_tracking.world.steering.approach`) and follows it again once on it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from resilient_tracking.world.steering import on_point
from resilient_tracking.world.target_motion import MOTIONS, Surroundings, TargetMotion


class ShadowedMotion(TargetMotion):
    """Base of the motions that leave their ``base`` motion and come back to it."""

    reacts = True

    def __init__(self, spec: Any, start: np.ndarray):
        super().__init__(spec, start)
        #: the base motion, run on as the shadow of where the target would be
        self.base: TargetMotion = MOTIONS.get(spec.base.type)(spec.base, start)
        self.velocity = self.base.velocity.copy()
        #: ``base`` while on the base motion, ``return`` while steering back to it; the
        #: motions add their own detours
        self.mode = "base"
        self._around: Surroundings | None = None

    def sense(self, surroundings: Surroundings) -> None:
        """Keep the world as seen for the next step (and hand it to the base)."""
        self._around = surroundings
        if self.base.reacts:
            self.base.sense(surroundings)

    def step_shadow(self, dt: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Step the base motion; its position at the step's start and its velocity over it."""
        shadow = self.base.position.copy()
        self.base.step(dt, rng)
        return shadow, (self.base.position - shadow) / dt

    def follow_base(self) -> None:
        """Be where the base motion is, moving as it does."""
        self.mode = "base"
        self.position, self.velocity = self.base.position.copy(), self.base.velocity.copy()

    def rejoin_if_on(self, shadow_velocity: np.ndarray, max_accel: float, dt: float) -> None:
        """While returning, follow the base again once on it."""
        if self.mode == "return" and on_point(
            self.position, self.velocity, self.base.position, shadow_velocity, max_accel, dt
        ):
            self.follow_base()
