"""The ``evasive`` target motion (docs/model.md §1): a base motion that flees robots.

The target follows its base motion while no robot is within ``radius`` of it (true positions,
seen through :class:`~resilient_tracking.world.target_motion.Surroundings`). When robots are
within it, it flees: the wanted heading is the sum of the unit vectors away from each of them,
weighted by closeness ``(radius − d)/radius``. Within ``wall_margin`` of a wall it does not
move closer to that wall: it slides along it (the heading without its part into the wall), or,
where no such heading leads away from the robots (a robot straight in front of a wall, or
across a corner), runs along a wall, the longer free way on a tie, and keeps to that escape
until fleeing no longer turns it back (so a corner does not hold it). Its velocity turns toward
``speed`` along the heading by at most ``max_accel · dt`` per step, and it never leaves the
workspace (a wall stops the part of a velocity into it at once).

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
from resilient_tracking.world.shadowed import ShadowedMotion
from resilient_tracking.world.steering import approach, free_run, move_inside, turn_toward
from resilient_tracking.world.target_motion import MOTIONS

#: Inward normals of the walls, in the order of ``[position − lower, upper − position]``:
#: left, bottom, right, top.
WALL_NORMALS = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])
#: Headings along the walls (the four axis directions), tried when fleeing leads into them.
WALL_HEADINGS = WALL_NORMALS
#: Slack (in cosine) of the comparisons between headings.
EPS = 1e-12


def flee_heading(
    position: np.ndarray,
    robots: np.ndarray,
    radius: float,
    lower: np.ndarray,
    upper: np.ndarray,
    wall_margin: float,
    escape: np.ndarray | None = None,
) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The unit heading to flee along from the robots within ``radius`` (``None`` when none
    is), and the escape heading to keep for the next step (``None`` when not cornered).

    ``escape`` is the one kept from the last step (module docstring)."""
    gaps = robots - position
    distance = row_norms(gaps)
    near = distance < radius
    if not near.any():
        return None, None
    d = distance[near]
    seen = d > 0  # a robot on the target gives no direction
    away = -(gaps[near][seen] / d[seen, None])
    push = (((radius - d[seen]) / radius)[:, None] * away).sum(axis=0)
    length = vector_length(push)
    flee = push / length if length > 0 else np.zeros(2)
    wall_gap = np.concatenate([position - lower, upper - position])
    walls = WALL_NORMALS[(wall_gap < wall_margin) | (wall_gap <= 0)]

    def allowed(heading: np.ndarray) -> bool:  # not closer to a wall within the margin
        return bool((walls @ heading >= -EPS).all())

    candidates = [flee] if length > 0 else []
    for normal in walls:  # the heading with its part into a near wall removed: a slide
        slide = flee - (flee @ normal) * normal
        slide_length = vector_length(slide)
        if slide_length > EPS:
            candidates.append(slide / slide_length)
    candidates += list(WALL_HEADINGS)
    options = [h for h in candidates if allowed(h) and free_run(position, h, lower, upper) > 0]
    if not options:
        return np.zeros(2), None  # boxed in on every side: stop
    best = max(
        options, key=lambda h: (round(float(h @ flee), 12), free_run(position, h, lower, upper))
    )
    cornered = len(walls) > 0 and best @ flee <= EPS  # nothing allowed leads away
    if escape is not None and allowed(escape) and free_run(position, escape, lower, upper) > 0:
        if cornered or best @ escape < -EPS:  # fleeing would turn back: keep escaping
            return escape, escape
        return best, None
    return best, (best if cornered else None)


@MOTIONS.register("evasive")
class EvasiveMotion(ShadowedMotion):
    """Its base motion, fleeing robots within ``radius`` (module docstring)."""

    Spec = Evasive

    def __init__(self, spec: Evasive, start: np.ndarray):
        super().__init__(spec, start)
        #: the heading along a wall a cornered target keeps to until fleeing leads on from it
        self._escape: np.ndarray | None = None

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Flee, steer back, or follow the base motion (module docstring)."""
        shadow, shadow_velocity = self.step_shadow(dt, rng)
        around, spec = self._around, self.spec
        heading = None
        if around is not None:
            heading, self._escape = flee_heading(
                self.position,
                around.robots,
                spec.radius,
                around.lower,
                around.upper,
                spec.wall_margin,
                self._escape,
            )
        if heading is None and self.mode == "base":
            self.follow_base()
            return
        if heading is not None:
            self.mode = "flee"
            wanted = spec.speed * heading
        else:
            self.mode = "return"
            wanted = approach(self.position, shadow, shadow_velocity, spec.speed)
        velocity = turn_toward(self.velocity, wanted, spec.speed, spec.max_accel, dt)
        if around is None:
            self.position, self.velocity = self.position + velocity * dt, velocity
        else:
            self.position, self.velocity = move_inside(
                self.position, velocity, dt, around.lower, around.upper
            )
        self.rejoin_if_on(shadow_velocity, spec.max_accel, dt)
