"""The ``lure`` target motion (docs/model.md §1): a base motion with trips into a danger zone.

The target knows where the zone called ``zone`` truly is (its centre drawn for the episode,
seen through :class:`~resilient_tracking.world.target_motion.Surroundings`), which the robots
do not. It follows its base motion until a trip is due: at time ``after``, then every
``period`` seconds (``null``: one trip); with ``near`` set, a due trip waits until a robot is
within ``near`` of the target, so that it leads its trackers in. On a trip it heads for the
zone's true centre (or, with ``standoff``, the point that far from it on the side it comes
from; inside the workspace) at most ``speed``, with acceleration at most ``max_accel``; within
5 cm of it, it lingers ``linger`` seconds holding there; then it steers back to its base motion.

The base motion runs on all the while as a shadow, from the same random stream as a plain
target of that motion, so the way back is to where the target would have been: its velocity
plus the gap over 0.5 s, at most ``speed``; once on it the target follows it exactly again. A
base motion faster than ``speed`` is never caught up with. Zones never attack targets.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from resilient_tracking.models.geometry import row_norms, vector_length
from resilient_tracking.scenario import Lure
from resilient_tracking.world.shadowed import ShadowedMotion
from resilient_tracking.world.steering import approach, move_inside, turn_toward
from resilient_tracking.world.target_motion import MOTIONS

log = logging.getLogger(__name__)

#: A trip's target is reached within this distance (m): the lingering starts.
ARRIVED = 0.05
#: Slack (s) of the time comparisons: the clock adds ``dt`` each step, with rounding.
TICK = 1e-9


@MOTIONS.register("lure")
class LureMotion(ShadowedMotion):
    """Its base motion, with trips to a zone's true centre (module docstring)."""

    Spec = Lure

    def __init__(self, spec: Lure, start: np.ndarray):
        super().__init__(spec, start)
        # modes ``go`` (to the zone) and ``linger`` besides ``base`` and ``return``
        #: time (s) since the start of the episode, at the start of the next step
        self.time = 0.0
        #: time the next trip is due; ``inf``: none is
        self.due = spec.after
        #: where the current trip leads, and when its lingering ends
        self.goal: np.ndarray | None = None
        self.linger_until = math.inf
        self._warned = False

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Follow the base motion, or go to the zone, linger, or steer back (module
        docstring)."""
        shadow, shadow_velocity = self.step_shadow(dt, rng)
        now, self.time = self.time, self.time + dt
        if self.mode == "base" and now + TICK >= self.due:
            self._maybe_set_off()
        if self.mode == "base":
            self.follow_base()
            return
        spec, around = self.spec, self._around
        assert around is not None and self.goal is not None  # a trip starts only with both
        if self.mode == "linger" and now + TICK >= self.linger_until:
            self.mode = "return"
        if self.mode == "return":
            wanted = approach(self.position, shadow, shadow_velocity, spec.speed)
        else:
            wanted = approach(self.position, self.goal, np.zeros(2), spec.speed)
        velocity = turn_toward(self.velocity, wanted, spec.speed, spec.max_accel, dt)
        self.position, self.velocity = move_inside(
            self.position, velocity, dt, around.lower, around.upper
        )
        if self.mode == "go" and vector_length(self.goal - self.position) <= ARRIVED:
            self.mode, self.linger_until = "linger", self.time + spec.linger
        else:
            self.rejoin_if_on(shadow_velocity, spec.max_accel, dt)

    def _maybe_set_off(self) -> None:
        """Start the due trip if the zone is known and (with ``near``) a robot is near."""
        spec, around = self.spec, self._around
        if around is None:
            return  # stepped outside a world (a mean path): no zone to go to
        zone = around.zone(spec.zone)
        if zone is None:
            if not self._warned:
                log.warning("lure target: no zone named %r; it keeps to its base motion", spec.zone)
                self._warned = True
            return
        if spec.near is not None and not (
            len(around.robots) and row_norms(around.robots - self.position).min() < spec.near
        ):
            return
        goal = zone.center
        if spec.standoff > 0:
            side = self.position - zone.center
            length = vector_length(side)
            side = side / length if length > 0 else np.array([1.0, 0.0])
            goal = zone.center + spec.standoff * side
        self.goal = np.clip(goal, around.lower, around.upper)
        self.mode = "go"
        self.due = math.inf if spec.period is None else self._next_due(spec.period)

    def _next_due(self, period: float) -> float:
        """The first time ``after + k · period`` later than now."""
        ratio = (self.time + TICK - self.spec.after) / period
        if not math.isfinite(ratio):  # a period too short to count in: due again at once
            return self.time
        return self.spec.after + max(math.floor(ratio) + 1, 1) * period
