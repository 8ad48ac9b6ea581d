"""The ``evasive`` target motion (docs/model.md §1): a base motion that flees robots.

The target follows its base motion while no robot is within ``radius`` of it (true positions,
seen through :class:`~resilient_tracking.world.target_motion.Surroundings`). When robots are
within it, it flees: the wanted heading is the sum of the unit vectors away from each of them,
weighted by closeness ``(radius − d)/radius``. Within ``wall_margin`` of a wall the part of that
heading into the wall fades out (to nothing at the wall), so the target slides along it; where
almost nothing is left (a robot straight in front of a wall, or in a corner) it runs along the
wall, the way least toward the robots, on ties the longer free way, out of the corner. Its
velocity turns toward ``speed`` along that heading by at most ``max_accel · dt`` per step, and
it never leaves the workspace.

The base motion runs on all the while as a shadow, from the same random stream as a plain
target of that motion, so it is where the target would have been. Once no robot is within
``radius`` the target steers back to the shadow (its velocity plus the gap over 0.5 s, at most
``speed``, the same acceleration bound) and, once on it, follows it exactly again. A base motion
faster than ``speed`` is never caught up with.
"""

from __future__ import annotations

import numpy as np

from resilient_tracking.models.geometry import row_norms, vector_length
from resilient_tracking.scenario import Evasive
from resilient_tracking.world.steering import (
    approach,
    free_run,
    move_inside,
    on_point,
    turn_toward,
)
from resilient_tracking.world.target_motion import MOTIONS, Surroundings, TargetMotion

#: Inward normals of the walls: left, right, bottom, top.
WALL_NORMALS = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
#: Headings tried when fleeing is stalled by walls: along the walls.
WALL_HEADINGS = WALL_NORMALS[[2, 3, 0, 1]]
#: Below this length (of a unit flee heading) the walls have stalled the flight.
STALLED = 0.25


def flee_heading(
    position: np.ndarray,
    robots: np.ndarray,
    radius: float,
    lower: np.ndarray,
    upper: np.ndarray,
    wall_margin: float,
) -> np.ndarray | None:
    """The unit heading to flee along from the robots within ``radius``; ``None`` when none
    is (module docstring)."""
    gaps = robots - position
    distance = row_norms(gaps)
    near = distance < radius
    if not near.any():
        return None
    d = distance[near]
    seen = d > 0  # a robot on the target gives no direction
    away = -(gaps[near][seen] / d[seen, None])
    push = (((radius - d[seen]) / radius)[:, None] * away).sum(axis=0)
    length = vector_length(push)
    heading = push / length if length > 0 else np.zeros(2)
    # the walls: fade out the part of the heading into each near wall
    wall_gap = np.concatenate([position - lower, upper - position])
    for normal, gap in zip(WALL_NORMALS, wall_gap, strict=True):
        into = float(heading @ normal)
        if into >= 0 or gap >= wall_margin > 0 or (wall_margin == 0 and gap > 0):
            continue
        fade = 1.0 if gap <= 0 else 1.0 - gap / wall_margin
        heading = heading - fade * into * normal
    length = vector_length(heading)
    if length >= STALLED:
        return heading / length
    return _along_walls(position, push, lower, upper)


def _along_walls(
    position: np.ndarray, push: np.ndarray, lower: np.ndarray, upper: np.ndarray
) -> np.ndarray:
    """Flight stalled: the open heading along a wall least toward the robots, on ties the
    longer free run (out of a corner along its longer side)."""
    best, best_key = WALL_HEADINGS[0], (-np.inf, -np.inf)
    for heading in WALL_HEADINGS:
        run = free_run(position, heading, lower, upper)
        if run <= 0:
            continue
        key = (round(float(heading @ push), 12), run)
        if key > best_key:
            best, best_key = heading, key
    return best.copy()


@MOTIONS.register("evasive")
class EvasiveMotion(TargetMotion):
    """Its base motion, fleeing robots within ``radius`` (module docstring)."""

    Spec = Evasive
    reacts = True

    def __init__(self, spec: Evasive, start: np.ndarray):
        super().__init__(spec, start)
        #: the base motion, run on as the shadow of where the target would be
        self.base: TargetMotion = MOTIONS.get(spec.base.type)(spec.base, start)
        self.velocity = self.base.velocity.copy()
        #: ``base`` (on the base motion), ``flee`` or ``return`` (steering back to it)
        self.mode = "base"
        self._around: Surroundings | None = None

    def sense(self, surroundings: Surroundings) -> None:
        """Keep the robots and the workspace for the next step (and hand them to the base)."""
        self._around = surroundings
        if self.base.reacts:
            self.base.sense(surroundings)

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Flee, steer back, or follow the base motion (module docstring)."""
        self.base.step(dt, rng)
        around, spec = self._around, self.spec
        heading = None
        if around is not None:
            heading = flee_heading(
                self.position,
                around.robots,
                spec.radius,
                around.lower,
                around.upper,
                spec.wall_margin,
            )
        if heading is None and self.mode == "base":
            self.position, self.velocity = self.base.position.copy(), self.base.velocity.copy()
            return
        if heading is not None:
            self.mode = "flee"
            wanted = spec.speed * heading
        else:
            self.mode = "return"
            wanted = approach(self.position, self.base.position, self.base.velocity, spec.speed)
        velocity = turn_toward(self.velocity, wanted, spec.speed, spec.max_accel, dt)
        if around is None:
            self.position, self.velocity = self.position + velocity * dt, velocity
        else:
            self.position, self.velocity = move_inside(
                self.position, velocity, dt, around.lower, around.upper
            )
        if self.mode == "return" and on_point(
            self.position,
            self.velocity,
            self.base.position,
            self.base.velocity,
            spec.max_accel,
            dt,
        ):
            self.mode = "base"
            self.position, self.velocity = self.base.position.copy(), self.base.velocity.copy()
