"""The built-in target motions (docs/model.md §1): constant velocity, nearly constant velocity
with white acceleration noise, a circle and waypoints."""

from __future__ import annotations

import numpy as np

from resilient_tracking.models.geometry import vector_length
from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.scenario import Circle, ConstantVelocity, NoisyConstantVelocity, Waypoints
from resilient_tracking.world.target_motion import MOTIONS, TargetMotion


@MOTIONS.register("constant_velocity")
class ConstantVelocityMotion(TargetMotion):
    """A straight line at the spec's velocity."""

    Spec = ConstantVelocity

    def __init__(self, spec: ConstantVelocity, start: np.ndarray):
        super().__init__(spec, start)
        self.velocity = np.array(spec.velocity, dtype=float)

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Move on at the current velocity."""
        self.position = self.position + self.velocity * dt


@MOTIONS.register("waypoints")
class WaypointsMotion(TargetMotion):
    """Straight segments through the points at constant speed, looping if asked."""

    Spec = Waypoints

    def __init__(self, spec: Waypoints, start: np.ndarray):
        super().__init__(spec, start)
        #: the points as arrays, once (every step reads them)
        self._points = [np.asarray(p, dtype=float) for p in spec.points]
        #: and as Python floats
        self._xy = [(float(x), float(y)) for x, y in self._points]
        self._next_waypoint = 0
        #: the last _to_goal: its (px, py, waypoint) and (dx, dy, dist)
        self._goal_for: tuple[float, float, int] | None = None
        self._goal: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.velocity = self._waypoint_velocity()

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Spend ``speed · dt`` of path, passing as many points as it reaches."""
        budget = self.spec.speed * dt
        points = self._points
        for _ in range(len(points) + 1):  # bounded: a loop of coincident points ends
            if budget <= 0 or self._next_waypoint >= len(points):
                break
            px, py = self.position.tolist()
            dx, dy, dist = self._to_goal(px, py)
            if dist <= budget:
                self.position = points[self._next_waypoint].copy()
                budget -= dist
                self._next_waypoint += 1
                if self.spec.loop and self._next_waypoint == len(points):
                    self._next_waypoint = 0
            else:
                # position + delta / dist * budget, per component in Python floats: the same
                # IEEE operations as NumPy's on a 2-vector, without its overhead per call
                self.position = np.array([px + dx / dist * budget, py + dy / dist * budget])
                budget = 0.0
        self.velocity = self._waypoint_velocity()

    def _waypoint_velocity(self) -> np.ndarray:
        if self._next_waypoint >= len(self._points):
            return np.zeros(2)
        dx, dy, dist = self._to_goal(*self.position.tolist())
        if dist == 0:
            return np.zeros(2)
        speed = self.spec.speed
        return np.array([dx / dist * speed, dy / dist * speed])  # delta / dist * speed, as above

    def _to_goal(self, px: float, py: float) -> tuple[float, float, float]:
        """``delta = goal − position`` of the next waypoint from ``(px, py)`` (the position)
        and its length. Kept for the position and waypoint it was made for: a step starts
        where the last velocity was found, so the next step's first one is the same."""
        key = (px, py, self._next_waypoint)
        if key != self._goal_for:
            gx, gy = self._xy[self._next_waypoint]
            dx, dy = gx - px, gy - py  # goal − position in floats: NumPy's numbers
            self._goal = (dx, dy, vector_length(np.array([dx, dy])))
            self._goal_for = key
        return self._goal


@MOTIONS.register("circle")
class CircleMotion(TargetMotion):
    """Around ``center`` through the start point at ``angular_speed`` (positive: CCW)."""

    Spec = Circle

    def __init__(self, spec: Circle, start: np.ndarray):
        super().__init__(spec, start)
        self._angle = float(np.arctan2(*(self.position - spec.center)[::-1]))
        self._radius = float(np.linalg.norm(self.position - spec.center))
        self.velocity = self._circle_velocity()

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """Turn by ``angular_speed · dt`` on the circle."""
        self._angle += self.spec.angular_speed * dt
        center = np.asarray(self.spec.center)
        self.position = center + self._radius * np.array([np.cos(self._angle), np.sin(self._angle)])
        self.velocity = self._circle_velocity()

    def _circle_velocity(self) -> np.ndarray:
        w, r, a = self.spec.angular_speed, self._radius, self._angle
        return np.array([-w * r * np.sin(a), w * r * np.cos(a)])


@MOTIONS.register("ncv")
class NoisyConstantVelocityMotion(TargetMotion):
    """Nearly constant velocity: white acceleration noise of ``accel_std`` per axis."""

    Spec = NoisyConstantVelocity

    def __init__(self, spec: NoisyConstantVelocity, start: np.ndarray):
        super().__init__(spec, start)
        self.velocity = np.array(spec.velocity, dtype=float)
        #: ``(dt, F, Q)`` of the last step's ``dt`` (the model's matrices are computed on access)
        self._matrices: tuple[float, np.ndarray, np.ndarray] | None = None

    def step(self, dt: float, rng: np.random.Generator) -> None:
        """``x ← F x + w`` with ``w ~ N(0, Q)`` of the NCV model (no draw when noise is off)."""
        if self._matrices is None or self._matrices[0] != dt:
            model = NearlyConstantVelocity(dt, self.spec.accel_std)
            self._matrices = (dt, model.transition, model.process_noise)
        _, transition, process_noise = self._matrices
        noise = (
            rng.multivariate_normal(np.zeros(4), process_noise, method="cholesky")
            if self.spec.accel_std > 0
            else np.zeros(4)
        )
        state = transition @ np.concatenate([self.position, self.velocity]) + noise
        self.position, self.velocity = state[:2], state[2:]
