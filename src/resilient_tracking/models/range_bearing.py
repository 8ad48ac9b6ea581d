"""The paper's sensor (docs/model.md §1, paper eq. 2): range and bearing to a point target.

Each channel has the inverse variance ``R⁻¹(d) = peak · exp(−shape · d)``, so the noise variance
is ``R(d) = exp(shape · d) / peak``; noise is drawn with that variance. A scenario selects it
with ``sensor: {type: range_bearing, range: {peak, shape}, bearing: {peak, shape}, max_range}``,
or with a ``sensor`` section without a type.
"""

from __future__ import annotations

import functools
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
    range_hessian,
    register_sensor,
    wrap_angle,
    wrap_angle_in_place,
)

_MIN_RANGE_SQUARED = np.array(MIN_RANGE**2)


class RangeBearingSpec(SensorSpec):
    """The robots' range-bearing sensor (paper eq. 2): noise per channel and an optional maximum
    range."""

    type: Literal["range_bearing"] = Field(
        "range_bearing", description="Selects this sensor; a section without a type is this one."
    )
    range: SensorChannel = Field(SensorChannel(), description="Noise of the range measurement.")
    bearing: SensorChannel = Field(SensorChannel(), description="Noise of the bearing measurement.")
    max_range: MaxRange | None = Field(
        None,
        description="Targets farther than this are not measured; null: no limit.",
        json_schema_extra={"unit": "m"},
    )


@register_sensor("range_bearing")
@dataclass(frozen=True)
class RangeBearingSensor(MeasurementModel):
    """Range and bearing to a point target; parameters per sensor channel."""

    range_peak: float = 15.0
    range_shape: float = 0.2
    bearing_peak: float = 15.0
    bearing_shape: float = 0.2
    max_range: float | None = None

    Spec: ClassVar[type[SensorSpec]] = RangeBearingSpec
    #: ``[range, bearing]``
    DIM: ClassVar[int] = 2
    ANGLES: ClassVar[tuple[int, ...]] = (1,)
    RANGE: ClassVar[int | None] = 0
    #: range peak, range shape, bearing peak, bearing shape
    N_PARAMETERS: ClassVar[int] = 4

    @classmethod
    def from_spec(cls, spec: Any) -> RangeBearingSensor:
        """The sensor of a :class:`RangeBearingSpec`."""
        return cls(
            range_peak=spec.range.peak,
            range_shape=spec.range.shape,
            bearing_peak=spec.bearing.peak,
            bearing_shape=spec.bearing.shape,
            max_range=spec.max_range,
        )

    @property
    def parameters(self) -> FloatArray:
        """``[range_peak, range_shape, bearing_peak, bearing_shape]``, the numbers the planners'
        programs take (paper eq. 2)."""
        return np.array([self.range_peak, self.range_shape, self.bearing_peak, self.bearing_shape])

    def predict(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """Noise-free measurement ``[‖p − x‖, atan2(Δy, Δx)]``; arrays broadcast over rows."""
        return self._predict(np.asarray(target, dtype=float) - np.asarray(robot, dtype=float))

    def linearise(
        self, robot: FloatArray, target: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """:meth:`predict`, :meth:`jacobian` and the noise variance at the predicted range, from
        one difference ``target − robot`` (a subclass that replaces one of them: its own)."""
        if not self._own_linearise:
            return super().linearise(robot, target)
        delta = np.asarray(target, dtype=float) - np.asarray(robot, dtype=float)
        h = self._predict(delta)
        return h, self._jacobian(delta), self.noise_variance(h[..., 0])

    @functools.cached_property
    def _own_linearise(self) -> bool:
        """Whether this sensor measures as this class does (a subclass may replace
        :meth:`predict`, :meth:`jacobian` or :meth:`noise_distance`)."""
        cls = type(self)
        return (
            cls.predict is RangeBearingSensor.predict
            and cls.jacobian is RangeBearingSensor.jacobian
            and cls.noise_distance is RangeBearingSensor.noise_distance
        )

    def _predict(self, delta: FloatArray) -> FloatArray:
        out = np.empty(delta.shape)
        dx, dy = delta[..., 0], delta[..., 1]
        np.hypot(dx, dy, out=out[..., 0])  # (written in place: no temporaries, same numbers)
        np.arctan2(dy, dx, out=out[..., 1])
        return out

    def noise_variance(self, distance: FloatArray | float) -> FloatArray:
        """Per-channel variance ``[R_range(d), R_bearing(d)]``."""
        d = np.asarray(distance, dtype=float)
        shapes, peaks, cap = self._constants
        # both channels at once (elementwise, so the same numbers as one at a time); capped
        # exponent: far beyond the sensor's reach the variance is huge but finite
        exponent = np.minimum(np.multiply(shapes, d[..., None]), cap)
        return np.divide(np.exp(exponent), peaks)  # type: ignore[no-any-return]

    @functools.cached_property
    def _constants(self) -> tuple[FloatArray, ...]:
        """The channels' shapes and peaks (``[range, bearing]``) and ``MAX_EXPONENT`` as
        float64 arrays (faster in NumPy operations than Python floats, the same numbers)."""
        shapes = np.array([self.range_shape, self.bearing_shape], dtype=float)
        peaks = np.array([self.range_peak, self.bearing_peak], dtype=float)
        return shapes, peaks, np.array(MAX_EXPONENT)

    def noise_distance(
        self, robot: FloatArray, target: FloatArray, measurement: FloatArray
    ) -> FloatArray:
        """The range channel of ``measurement``: the distance itself."""
        return np.asarray(measurement)[..., 0]

    def jacobian(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """Jacobian of the measurement w.r.t. the target position: rows ``δᵀ/d`` (range) and
        ``[−δy, δx]/d²`` (bearing), ``d`` clamped at ``MIN_RANGE``; broadcasts, ``(..., 2, 2)``."""
        return self._jacobian(np.asarray(target, dtype=float) - np.asarray(robot, dtype=float))

    def _jacobian(self, delta: FloatArray) -> FloatArray:
        squares = delta * delta  # [dx², dy²]
        d2 = np.maximum(squares[..., 0] + squares[..., 1], _MIN_RANGE_SQUARED)
        d = np.sqrt(d2)
        out = np.empty(d.shape + (2, 2))  # rows divided in place: no temporaries, same numbers
        np.divide(delta, d[..., None], out=out[..., 0, :])  # range row [dx, dy] / d
        np.divide(delta[..., ::-1], d2[..., None], out=out[..., 1, :])  # bearing [−dy, dx] / d²:
        np.negative(out[..., 1, 0], out=out[..., 1, 0])  # (−dy)/d² is −(dy/d²) exactly
        return out

    def hessian(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """Hessians of range and bearing w.r.t. the target position, ``(..., 2, 2, 2)``."""
        delta = np.asarray(target, dtype=float) - np.asarray(robot, dtype=float)
        return np.stack([range_hessian(delta), bearing_hessian(delta)], axis=-3)

    def in_range(self, distance: FloatArray | float) -> NDArray[np.bool_]:
        """Whether a target at this distance (m) is measured: within ``max_range``, or always when
        there is none; broadcasts."""
        d = np.asarray(distance, dtype=float)
        if self.max_range is None:
            return np.ones_like(d, dtype=bool)
        return d <= self.max_range

    def in_range_everywhere(self) -> bool:
        """No ``max_range`` (and :meth:`in_range` as here, not a subclass's own)."""
        return self.max_range is None and type(self).in_range is RangeBearingSensor.in_range

    def sample(self, robot: FloatArray, target: FloatArray, rng: np.random.Generator) -> FloatArray:
        """A noisy measurement, noise drawn with variance ``R(d)`` (bearing wrapped)."""
        if not self._own_sample:
            clean = self.predict(robot, target)
            std = np.sqrt(self.noise_variance(clean[..., 0]))
            z = clean + std * rng.standard_normal(clean.shape)
            z[..., 1] = wrap_angle(z[..., 1])
            return z
        # predict, noise_variance and wrap_angle inline (this class's own): the same
        # operations without their calls and conversions; the range as a (..., 1) column
        clean = self._predict(np.asarray(target, dtype=float) - np.asarray(robot, dtype=float))
        shapes, peaks, cap = self._constants
        exponent = np.minimum(np.multiply(shapes, clean[..., 0:1]), cap)
        std = np.sqrt(np.divide(np.exp(exponent), peaks))
        z = clean + std * rng.standard_normal(clean.shape)
        wrap_angle_in_place(z[..., 1])
        return z

    @functools.cached_property
    def _own_sample(self) -> bool:
        """Whether this sensor samples as this class does (a subclass may replace
        :meth:`predict` or :meth:`noise_variance`)."""
        cls = type(self)
        return (
            cls.predict is RangeBearingSensor.predict
            and cls._predict is RangeBearingSensor._predict
            and cls.noise_variance is RangeBearingSensor.noise_variance
        )

    def information(
        self, robot: FloatArray, target: FloatArray, eps: float = PLAN_EPS
    ) -> FloatArray:
        """Entries ``(xx, xy, yy)`` (last axis) of ``Hᵀ R⁻¹ H`` of a sensor at ``robot`` seeing
        ``target`` (paper eq. 2), ``d² = ‖p − x‖² + eps²``; broadcasts. The NumPy twin of
        :meth:`information_casadi`."""
        delta = np.asarray(target, dtype=float) - np.asarray(robot, dtype=float)
        dx, dy = delta[..., 0], delta[..., 1]
        d2 = dx * dx + dy * dy + eps**2
        d = np.sqrt(d2)
        info_r = self.range_peak * np.exp(-self.range_shape * d) / d2
        info_b = self.bearing_peak * np.exp(-self.bearing_shape * d) / (d2 * d2)
        return np.stack(
            [
                info_r * dx * dx + info_b * dy * dy,
                (info_r - info_b) * dx * dy,
                info_r * dy * dy + info_b * dx * dx,
            ],
            axis=-1,
        )

    @staticmethod
    def information_casadi(
        x: Any, p: Any, params: Any, eps: float = PLAN_EPS
    ) -> tuple[Any, Any, Any]:
        """``Hᵀ R⁻¹ H`` with ``d² = ‖p − x‖² + eps²``: the range row is ``δᵀ/d``, the
        bearing row ``[−δy, δx]/d²`` (paper eq. 2)."""
        delta = p - x
        d2 = ca.sumsqr(delta) + eps**2
        d = ca.sqrt(d2)
        info_r = params[0] * ca.exp(-params[1] * d) / d2  # range row is δᵀ/d
        info_b = params[2] * ca.exp(-params[3] * d) / (d2 * d2)  # bearing row is [−δy, δx]/d²
        dx, dy = delta[0], delta[1]
        return (
            info_r * dx * dx + info_b * dy * dy,
            (info_r - info_b) * dx * dy,
            info_r * dy * dy + info_b * dx * dx,
        )

    @staticmethod
    def information_derivatives_casadi(
        x: Any, p: Any, params: Any, eps: float = PLAN_EPS
    ) -> tuple[Any, Any, Any]:
        """:meth:`information_casadi` with its first and second derivatives, by hand.

        ``m = φ_r(ρ) v_r(δ) + φ_b(ρ) v_b(δ)`` with ``δ = p − x``, ``ρ = ‖δ‖² + ε²``,
        ``φ(ρ) = peak e^{−shape √ρ} ρ^{−k}`` (``k = 1`` range, ``2`` bearing),
        ``v_r = (δx², δxδy, δy²)`` and ``v_b = (δy², −δxδy, δx²)``.
        """
        dx, dy = p[0] - x[0], p[1] - x[1]
        rho = dx * dx + dy * dy + eps**2
        root = ca.sqrt(rho)
        v = {"r": (dx * dx, dx * dy, dy * dy), "b": (dy * dy, -dx * dy, dx * dx)}
        # ∂v/∂δx, ∂v/∂δy and the constant second derivatives (xx, xy, yy)
        dv = {"r": ((2 * dx, dy, 0), (0, dx, 2 * dy)), "b": ((0, -dy, 2 * dx), (2 * dy, -dx, 0))}
        ddv = {"r": ((2, 0, 0), (0, 1, 0), (0, 0, 2)), "b": ((0, 0, 2), (0, -1, 0), (2, 0, 0))}
        m = [0, 0, 0]
        jac = [[0, 0], [0, 0], [0, 0]]  # w.r.t. δ
        hess = [[0, 0, 0], [0, 0, 0], [0, 0, 0]]  # w.r.t. δ: xx, xy, yy
        d = (dx, dy)
        channels = (("r", params[0], params[1], 1), ("b", params[2], params[3], 2))
        for channel, peak, shape, k in channels:
            phi = peak * ca.exp(-shape * root) / (rho if k == 1 else rho * rho)
            l1 = -shape / (2 * root) - k / rho
            phi1 = phi * l1
            phi2 = phi * (l1 * l1 + shape / (4 * rho * root) + k / (rho * rho))
            for r in range(3):
                vr = v[channel][r]
                m[r] = m[r] + phi * vr
                for a in range(2):
                    jac[r][a] = jac[r][a] + 2 * phi1 * d[a] * vr + phi * dv[channel][a][r]
                for e, (a, b) in enumerate(((0, 0), (0, 1), (1, 1))):
                    term = 4 * phi2 * d[a] * d[b] * vr + phi * ddv[channel][e][r]
                    term = term + 2 * phi1 * (
                        (vr if a == b else 0) + d[a] * dv[channel][b][r] + d[b] * dv[channel][a][r]
                    )
                    hess[r][e] = hess[r][e] + term
        # x = p − δ: the Jacobian flips sign, the Hessian does not
        jac_x = ca.vertcat(*[ca.horzcat(-jac[r][0], -jac[r][1]) for r in range(3)])
        hess_x = ca.vertcat(*[ca.horzcat(*hess[r]) for r in range(3)])
        return ca.vertcat(*m), jac_x, hess_x
