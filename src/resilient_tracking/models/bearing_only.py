"""A bearing-only sensor (a camera): the direction to a target, no range (docs/model.md §1).

The measurement is the bearing ``atan2(Δy, Δx)`` of the target ``p`` seen from the robot ``x``,
``Δ = p − x``, with the inverse variance of the paper's bearing channel (eq. 2),
``R⁻¹(d) = peak · exp(−shape · d)``. One robot's measurement only fixes a line through the
target; several robots at different positions, or one that moves, make it observable. A
scenario selects it with ``sensor: {type: bearing_only, bearing: {peak, shape}, max_range}``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import casadi as ca
import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from resilient_tracking.models.sensor import (
    MAX_EXPONENT,
    MIN_RANGE,
    PLAN_EPS,
    FloatArray,
    MaxRange,
    MeasurementModel,
    SensorChannel,
    SensorSpec,
    bearing_hessian,
    register_sensor,
    wrap_angle,
)


class BearingOnlySpec(SensorSpec):
    """A bearing-only sensor (a camera): the direction to each target, with the noise of the
    paper's bearing channel, and an optional maximum range."""

    type: Literal["bearing_only"] = Field(description="Selects this sensor.")
    bearing: SensorChannel = Field(SensorChannel(), description="Noise of the bearing measurement.")
    max_range: MaxRange | None = Field(
        None,
        description="Targets farther than this are not measured; null: no limit.",
        json_schema_extra={"unit": "m"},
    )


@register_sensor("bearing_only")
@dataclass(frozen=True)
class BearingOnlySensor(MeasurementModel):
    """Bearing to a point target, inverse variance ``peak · exp(−shape · d)``."""

    bearing_peak: float = 15.0
    bearing_shape: float = 0.2
    max_range: float | None = None

    Spec: ClassVar[type[SensorSpec]] = BearingOnlySpec
    #: ``[bearing]``
    DIM: ClassVar[int] = 1
    ANGLES: ClassVar[tuple[int, ...]] = (0,)
    #: bearing peak, bearing shape
    N_PARAMETERS: ClassVar[int] = 2

    @classmethod
    def from_spec(cls, spec: Any) -> BearingOnlySensor:
        """The sensor of a :class:`BearingOnlySpec`."""
        return cls(
            bearing_peak=spec.bearing.peak,
            bearing_shape=spec.bearing.shape,
            max_range=spec.max_range,
        )

    @property
    def parameters(self) -> FloatArray:
        """``[bearing_peak, bearing_shape]``, the numbers the planners' programs take."""
        return np.array([self.bearing_peak, self.bearing_shape])

    def predict(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """Noise-free measurement ``[atan2(Δy, Δx)]``; arrays broadcast over rows."""
        delta = np.asarray(target, dtype=float) - np.asarray(robot, dtype=float)
        return np.arctan2(delta[..., 1], delta[..., 0])[..., None]

    def noise_variance(self, distance: FloatArray | float) -> FloatArray:
        """Variance ``[R(d)]`` with ``R(d) = exp(shape · d) / peak`` (exponent capped)."""
        d = np.asarray(distance, dtype=float)
        exponent = np.minimum(self.bearing_shape * d, MAX_EXPONENT)
        return (np.exp(exponent) / self.bearing_peak)[..., None]

    def noise_distance(
        self, robot: FloatArray, target: FloatArray, measurement: FloatArray
    ) -> FloatArray:
        """``‖p − x‖``: a bearing does not carry the distance, the positions do."""
        delta = np.asarray(target, dtype=float) - np.asarray(robot, dtype=float)
        return np.hypot(delta[..., 0], delta[..., 1])

    def jacobian(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """The bearing row ``[−δy, δx] / d²`` w.r.t. the target position, ``d`` clamped at
        ``MIN_RANGE``; broadcasts, ``(..., 1, 2)``."""
        delta = np.asarray(target, dtype=float) - np.asarray(robot, dtype=float)
        dx, dy = delta[..., 0], delta[..., 1]
        d2 = np.maximum(dx * dx + dy * dy, MIN_RANGE**2)
        return np.stack([-dy / d2, dx / d2], axis=-1)[..., None, :]

    def hessian(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """The bearing's Hessian w.r.t. the target position, ``(..., 1, 2, 2)``."""
        delta = np.asarray(target, dtype=float) - np.asarray(robot, dtype=float)
        return bearing_hessian(delta)[..., None, :, :]

    def in_range(self, distance: FloatArray | float) -> NDArray[np.bool_]:
        """Whether a target at this distance (m) is measured: within ``max_range``, or always when
        there is none; broadcasts."""
        d = np.asarray(distance, dtype=float)
        if self.max_range is None:
            return np.ones_like(d, dtype=bool)
        return d <= self.max_range

    def in_range_everywhere(self) -> bool:
        """No ``max_range`` (and :meth:`in_range` as here, not a subclass's own)."""
        return self.max_range is None and type(self).in_range is BearingOnlySensor.in_range

    def sample(self, robot: FloatArray, target: FloatArray, rng: np.random.Generator) -> FloatArray:
        """A noisy bearing, noise drawn with variance ``R(d)``, wrapped to [−π, π)."""
        clean = self.predict(robot, target)
        distance = self.noise_distance(robot, target, clean)
        std = np.sqrt(self.noise_variance(distance))
        return np.asarray(wrap_angle(clean + std * rng.standard_normal(clean.shape)))

    def information(
        self, robot: FloatArray, target: FloatArray, eps: float = PLAN_EPS
    ) -> FloatArray:
        """Entries ``(xx, xy, yy)`` (last axis) of ``Hᵀ R⁻¹ H`` with ``H = [−δy, δx]/d²`` and
        ``d² = ‖p − x‖² + eps²``; broadcasts. The NumPy twin of :meth:`information_casadi`."""
        delta = np.asarray(target, dtype=float) - np.asarray(robot, dtype=float)
        dx, dy = delta[..., 0], delta[..., 1]
        d2 = dx * dx + dy * dy + eps**2
        info = self.bearing_peak * np.exp(-self.bearing_shape * np.sqrt(d2)) / (d2 * d2)
        return np.stack([info * dy * dy, -info * dx * dy, info * dx * dx], axis=-1)

    @staticmethod
    def information_casadi(
        x: Any, p: Any, params: Any, eps: float = PLAN_EPS
    ) -> tuple[Any, Any, Any]:
        """``Hᵀ R⁻¹ H`` with ``d² = ‖p − x‖² + eps²`` and the bearing row ``[−δy, δx]/d²``."""
        delta = p - x
        d2 = ca.sumsqr(delta) + eps**2
        info = params[0] * ca.exp(-params[1] * ca.sqrt(d2)) / (d2 * d2)
        dx, dy = delta[0], delta[1]
        return info * dy * dy, -info * dx * dy, info * dx * dx

    @staticmethod
    def information_derivatives_casadi(
        x: Any, p: Any, params: Any, eps: float = PLAN_EPS
    ) -> tuple[Any, Any, Any]:
        """:meth:`information_casadi` with its first and second derivatives, by hand.

        ``m = φ(ρ) v(δ)`` with ``δ = p − x``, ``ρ = ‖δ‖² + ε²``,
        ``φ(ρ) = peak e^{−shape √ρ} ρ^{−2}`` and ``v = (δy², −δxδy, δx²)``; by the chain rule
        ``∂m/∂δ_a = 2φ′ δ_a v + φ ∂_a v`` and
        ``∂²m/∂δ_a∂δ_b = 4φ″ δ_a δ_b v + 2φ′ (1[a=b] v + δ_a ∂_b v + δ_b ∂_a v) + φ ∂_ab v``.
        """
        peak, shape = params[0], params[1]
        dx, dy = p[0] - x[0], p[1] - x[1]
        rho = dx * dx + dy * dy + eps**2
        root = ca.sqrt(rho)
        phi = peak * ca.exp(-shape * root) / (rho * rho)
        log1 = -shape / (2 * root) - 2 / rho  # φ′/φ
        phi1 = phi * log1
        phi2 = phi * (log1 * log1 + shape / (4 * rho * root) + 2 / (rho * rho))
        d = (dx, dy)
        v = (dy * dy, -dx * dy, dx * dx)
        dv = ((0, -dy, 2 * dx), (2 * dy, -dx, 0))  # ∂v/∂δx, ∂v/∂δy
        ddv = ((0, 0, 2), (0, -1, 0), (2, 0, 0))  # ∂²v/∂δx², ∂²v/∂δx∂δy, ∂²v/∂δy²
        pairs = ((0, 0), (0, 1), (1, 1))
        jac, hess = [], []
        for r in range(3):
            # x = p − δ: the Jacobian flips sign, the Hessian does not
            jac.append(ca.horzcat(*[-(2 * phi1 * d[a] * v[r] + phi * dv[a][r]) for a in range(2)]))
            hess.append(
                ca.horzcat(
                    *[
                        4 * phi2 * d[a] * d[b] * v[r]
                        + 2 * phi1 * ((v[r] if a == b else 0) + d[a] * dv[b][r] + d[b] * dv[a][r])
                        + phi * ddv[e][r]
                        for e, (a, b) in enumerate(pairs)
                    ]
                )
            )
        return ca.vertcat(*[phi * vr for vr in v]), ca.vertcat(*jac), ca.vertcat(*hess)
