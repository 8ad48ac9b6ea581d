"""Scripted truth motion of the targets (docs/model.md §1)."""

from __future__ import annotations

import numpy as np

from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.scenario import (
    Circle,
    ConstantVelocity,
    NoisyConstantVelocity,
    TargetSpec,
    Waypoints,
)


class TargetTruth:
    """One target's true position and velocity, advanced by its scripted motion."""

    def __init__(self, spec: TargetSpec):
        self.spec = spec
        self.position = np.array(spec.start, dtype=float)
        self.velocity = np.zeros(2)
        self._next_waypoint = 0
        motion = spec.motion
        if isinstance(motion, ConstantVelocity | NoisyConstantVelocity):
            self.velocity = np.array(motion.velocity, dtype=float)
        elif isinstance(motion, Circle):
            self._angle = float(np.arctan2(*(self.position - motion.center)[::-1]))
            self._radius = float(np.linalg.norm(self.position - motion.center))
            self.velocity = self._circle_velocity(motion)
        elif isinstance(motion, Waypoints):
            #: the waypoints as arrays, once (the motion reads them every step)
            self._points = [np.asarray(p, dtype=float) for p in motion.points]
            self.velocity = self._waypoint_velocity(motion)

    @property
    def state(self) -> np.ndarray:
        """``[px, py, vx, vy]``."""
        return np.concatenate([self.position, self.velocity])

    def step(self, dt: float, rng: np.random.Generator) -> None:
        motion = self.spec.motion
        if isinstance(motion, ConstantVelocity):
            self.position = self.position + self.velocity * dt
        elif isinstance(motion, NoisyConstantVelocity):
            model = NearlyConstantVelocity(dt, motion.accel_std)
            noise = (
                rng.multivariate_normal(np.zeros(4), model.process_noise, method="cholesky")
                if motion.accel_std > 0
                else np.zeros(4)
            )
            state = model.transition @ self.state + noise
            self.position, self.velocity = state[:2], state[2:]
        elif isinstance(motion, Circle):
            self._angle += motion.angular_speed * dt
            center = np.asarray(motion.center)
            self.position = center + self._radius * np.array(
                [np.cos(self._angle), np.sin(self._angle)]
            )
            self.velocity = self._circle_velocity(motion)
        elif isinstance(motion, Waypoints):
            self._advance_waypoints(motion, dt)

    def _circle_velocity(self, motion: Circle) -> np.ndarray:
        w, r, a = motion.angular_speed, self._radius, self._angle
        return np.array([-w * r * np.sin(a), w * r * np.cos(a)])

    def _waypoint_velocity(self, motion: Waypoints) -> np.ndarray:
        if self._next_waypoint >= len(motion.points):
            return np.zeros(2)
        delta = self._points[self._next_waypoint] - self.position
        dist = _length(delta)
        return np.zeros(2) if dist == 0 else delta / dist * motion.speed

    def _advance_waypoints(self, motion: Waypoints, dt: float) -> None:
        budget = motion.speed * dt
        for _ in range(len(motion.points) + 1):  # bounded: a loop of coincident points ends
            if budget <= 0 or self._next_waypoint >= len(motion.points):
                break
            goal = self._points[self._next_waypoint]
            delta = goal - self.position
            dist = _length(delta)
            if dist <= budget:
                self.position = goal
                budget -= dist
                self._next_waypoint += 1
                if motion.loop and self._next_waypoint == len(motion.points):
                    self._next_waypoint = 0
            else:
                self.position = self.position + delta / dist * budget
                budget = 0.0
        self.velocity = self._waypoint_velocity(motion)


def _length(v: np.ndarray) -> float:
    """``‖v‖`` of a 1-D vector computed as ``np.linalg.norm`` does (``√(v·v)``), without its
    argument checks (called every step)."""
    return float(np.sqrt(v.dot(v)))
