"""Measurement models: what a robot's sensor measures of a target, and how much it tells.

:class:`MeasurementModel` is the interface every consumer goes through — the world (sampling),
the EKF (measurement, Jacobian, noise, which channels are angles), the league NLP and the SOG
program (the information ``Hᵀ R⁻¹ H`` a sensor would contribute from a planned position, in
CasADi form). A measurement has :attr:`~MeasurementModel.DIM` channels, so a team's
measurements are ``(M, N, DIM)``.

A sensor type is one class with its ``Spec`` (the pydantic model of the scenario's ``sensor``
section, a :class:`SensorSpec` whose ``type`` names it), registered in :data:`SENSORS` with
``@register_sensor("name")`` or an entry point of the group ``resilient_tracking.sensors``; a
scenario selects it with ``sensor: {type: name, ...}``. The planners take the class from the
team's sensor (``Structure.sensor_model``) and size their parameters by its ``N_PARAMETERS``
(tests/test_sensor_model_choice.py builds both programs on a five-parameter sensor).

:class:`RangeBearingSensor` is the paper's sensor (docs/model.md §1, paper eq. 2): range and
bearing with inverse variance ``R⁻¹(d) = peak · exp(−shape · d)`` per channel, so the noise
variance is ``R(d) = exp(shape · d) / peak``; noise is drawn with that variance.
"""

from __future__ import annotations

import functools
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Annotated, Any, ClassVar, Literal

import casadi as ca
import numpy as np
from numpy.typing import NDArray
from pydantic import Field

from resilient_tracking.registry import Registry
from resilient_tracking.spec import (
    MAX_DECAY,
    MAX_INFORMATION,
    MAX_LENGTH,
    MIN_INFORMATION,
    Strict,
)

FloatArray = NDArray[np.float64]
#: A sensor's maximum range (m): positive, at most :data:`~resilient_tracking.spec.MAX_LENGTH`.
MaxRange = Annotated[float, Field(gt=0, le=MAX_LENGTH)]

#: Distances below this are treated as this (the bearing is undefined at zero range).
MIN_RANGE = 1e-3
#: Cap on ``shape · d`` in the noise model: ``exp(600)`` keeps variances finite, far from overflow.
MAX_EXPONENT = 600.0
#: Distance regularisation (m) of the planners' information model: ``d² → d² + PLAN_EPS²``.
PLAN_EPS = 0.05
#: Relative step of :meth:`MeasurementModel.hessian`'s central differences (of the distance).
HESSIAN_STEP = 1e-5

_MIN_RANGE_SQUARED = np.array(MIN_RANGE**2)


#: π and 2π as 0-d float64 arrays: NumPy combines one with a float64 array faster than a
#: Python float (the same operation, so the same numbers)
_PI, _TWO_PI = np.array(np.pi), np.array(2.0 * np.pi)


def wrap_angle(a: FloatArray | float) -> FloatArray | float:
    """Wrap angles to [−π, π)."""
    x = np.asarray(a)
    if x.dtype == np.float64:  # the usual case, with the constants as float64 arrays
        return np.subtract(np.remainder(np.add(x, _PI), _TWO_PI), _PI)  # type: ignore[no-any-return]
    return (x + np.pi) % (2.0 * np.pi) - np.pi


def wrap_angle_in_place(a: FloatArray) -> None:
    """:func:`wrap_angle` of the float64 array ``a``, written into ``a`` (a view may be
    given: its base is changed)."""
    np.subtract(np.remainder(np.add(a, _PI), _TWO_PI), _PI, out=a)


def range_hessian(delta: FloatArray) -> FloatArray:
    """Hessian of the range ``‖δ‖`` w.r.t. the target, ``(I − uuᵀ)/d`` (``u = δ/d``, ``d``
    clamped at ``MIN_RANGE``), for offsets ``δ = p − x`` ``(..., 2)``: ``(..., 2, 2)``."""
    dx, dy = delta[..., 0], delta[..., 1]
    d2 = np.maximum(dx * dx + dy * dy, MIN_RANGE**2)
    d3 = d2 * np.sqrt(d2)
    out = np.empty(dx.shape + (2, 2))
    out[..., 0, 0] = dy * dy / d3
    out[..., 0, 1] = out[..., 1, 0] = -dx * dy / d3
    out[..., 1, 1] = dx * dx / d3
    return out


def bearing_hessian(delta: FloatArray) -> FloatArray:
    """Hessian of the bearing ``atan2(δy, δx)`` w.r.t. the target,
    ``[[2δxδy, δy² − δx²], [δy² − δx², −2δxδy]] / d⁴`` (``d`` clamped at ``MIN_RANGE``), for
    offsets ``δ = p − x`` ``(..., 2)``: ``(..., 2, 2)``."""
    dx, dy = delta[..., 0], delta[..., 1]
    d4 = np.maximum(dx * dx + dy * dy, MIN_RANGE**2) ** 2
    out = np.empty(dx.shape + (2, 2))
    out[..., 0, 0] = 2.0 * dx * dy / d4
    out[..., 0, 1] = out[..., 1, 0] = (dy * dy - dx * dx) / d4
    out[..., 1, 1] = -2.0 * dx * dy / d4
    return out


# ---------------------------------------------------------------------------- parameters


class SensorSpec(Strict):
    """Base of a sensor's parameters; ``type`` selects the measurement model by its registered
    name (:data:`SENSORS`)."""

    type: str = Field(description="Selects the sensor: a registered name or package.module:Class.")

    def model(self) -> MeasurementModel:
        """The measurement model this section declares."""
        return SENSORS.get(self.type).from_spec(self)


class SensorChannel(Strict):
    """One channel: inverse variance ``peak · exp(−shape · d)``."""

    peak: float = Field(
        15.0,
        ge=MIN_INFORMATION,
        le=MAX_INFORMATION,
        description="Inverse variance at distance 0 (m⁻² for range, rad⁻² for bearing).",
        json_schema_extra={"unit": "1/variance"},
    )
    shape: float = Field(
        0.2,
        ge=0,
        le=MAX_DECAY,
        description="Decay rate of the information with distance; 0: independent of distance.",
        json_schema_extra={"unit": "1/m"},
    )


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


# ---------------------------------------------------------------------------- models


class MeasurementModel(ABC):
    """A sensor's measurement of a point target, in NumPy (filtering) and CasADi (planning).

    A measurement has :attr:`DIM` channels; those in :attr:`ANGLES` are angles, whose
    innovations the EKF wraps to [−π, π). The planners see a model only through
    :attr:`parameters`, a numeric vector of :attr:`N_PARAMETERS` entries that is a parameter of
    their programs (so one compiled problem serves every sensor of the type), and the
    class-level CasADi forms that take it.
    """

    #: the pydantic model of the ``sensor`` section this model reads
    Spec: ClassVar[type[SensorSpec]]
    #: number of channels of one measurement
    DIM: ClassVar[int]
    #: indices of the channels that are angles (wrapped to [−π, π))
    ANGLES: ClassVar[tuple[int, ...]]
    #: index of the channel that is a range, where a degraded sensor's bias is added
    #: (docs/model.md §2); None: the sensor measures no range
    RANGE: ClassVar[int | None] = None
    #: length of :attr:`parameters`
    N_PARAMETERS: ClassVar[int]

    @classmethod
    def from_spec(cls, spec: Any) -> MeasurementModel:
        """The model with the parameters of ``spec`` (a ``Spec``)."""
        raise NotImplementedError(f"{cls.__name__} must define from_spec")

    @property
    @abstractmethod
    def parameters(self) -> FloatArray:
        """The model's numbers as the planners' programs take them."""

    @abstractmethod
    def predict(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """Noise-free measurement; arrays broadcast over leading axes."""

    @abstractmethod
    def noise_variance(self, distance: FloatArray | float) -> FloatArray:
        """Per-channel noise variance at this distance, ``(..., DIM)``."""

    @abstractmethod
    def noise_distance(
        self, robot: FloatArray, target: FloatArray, measurement: FloatArray
    ) -> FloatArray:
        """The distance (m) at which the noise of ``measurement = predict(robot, target)`` is
        evaluated; a model with a range channel may read it from ``measurement``."""

    @abstractmethod
    def jacobian(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """Jacobian of the measurement w.r.t. the target position; broadcasts,
        ``(..., DIM, 2)``."""

    def hessian(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """Second derivatives of each measurement channel w.r.t. the target position,
        ``(..., DIM, 2, 2)``; what the EKF's second-order update needs. This default takes
        central differences of :meth:`jacobian`; a model with a closed form overrides it."""
        robot = np.asarray(robot, dtype=float)
        target = np.asarray(target, dtype=float)
        scale = np.maximum(np.linalg.norm(target - robot, axis=-1), MIN_RANGE)
        step = (HESSIAN_STEP * scale)[..., None]
        columns = []
        for axis in range(2):
            e = np.zeros(2)
            e[axis] = 1.0
            ahead = self.jacobian(robot, target + step * e)
            behind = self.jacobian(robot, target - step * e)
            columns.append((ahead - behind) / (2.0 * step[..., None]))
        hess = np.stack(columns, axis=-1)  # (..., DIM, 2, 2): [..., c, i, j] = ∂H_ci/∂p_j
        return np.asarray(0.5 * (hess + np.swapaxes(hess, -1, -2)), dtype=float)

    def linearise(
        self, robot: FloatArray, target: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """What the EKF linearises with, at once: :meth:`predict`, :meth:`jacobian` and
        :meth:`noise_variance` at :meth:`noise_distance`; a model may share work between them
        (the same numbers as the three calls)."""
        h = self.predict(robot, target)
        variance = self.noise_variance(self.noise_distance(robot, target, h))
        return h, self.jacobian(robot, target), variance

    @abstractmethod
    def in_range(self, distance: FloatArray | float) -> NDArray[np.bool_]:
        """Whether a target at this distance is measured at all."""

    def in_range_everywhere(self) -> bool:
        """Whether :meth:`in_range` is true at every distance (no range limit), so the world
        need not compute distances to ask it; ``False`` (ask :meth:`in_range`) by default."""
        return False

    @abstractmethod
    def sample(self, robot: FloatArray, target: FloatArray, rng: np.random.Generator) -> FloatArray:
        """A noisy measurement."""

    @abstractmethod
    def information(
        self, robot: FloatArray, target: FloatArray, eps: float = PLAN_EPS
    ) -> FloatArray:
        """Entries ``(xx, xy, yy)`` (last axis) of the planners' ``Hᵀ R⁻¹ H`` of a sensor at
        ``robot`` seeing ``target``, distances regularised by ``eps``; broadcasts. The NumPy
        twin of :meth:`information_casadi`."""

    @staticmethod
    @abstractmethod
    def information_casadi(
        x: Any, p: Any, params: Any, eps: float = PLAN_EPS
    ) -> tuple[Any, Any, Any]:
        """Entries ``(xx, xy, yy)`` of ``Hᵀ R⁻¹ H`` of a sensor at ``x`` seeing ``p``, with
        the model's numbers ``params`` (CasADi SX, MX or DM), distances regularised by
        ``eps``."""

    @staticmethod
    @abstractmethod
    def information_derivatives_casadi(
        x: Any, p: Any, params: Any, eps: float = PLAN_EPS
    ) -> tuple[Any, Any, Any]:
        """``m = (xx, xy, yy)`` of :meth:`information_casadi`, its Jacobian ``∂m/∂x`` (3×2)
        and its Hessians (3×3: row ``r`` holds ``∂²m_r/∂x²`` as ``[xx, xy, yy]``)."""


#: Measurement models by name: the built-ins, the entry points of the group
#: ``resilient_tracking.sensors`` and dotted paths ``package.module:Class``.
SENSORS: Registry[type[MeasurementModel]] = Registry(
    "sensor",
    "resilient_tracking.sensors",
    MeasurementModel,
    builtins=("resilient_tracking.models.sensor", "resilient_tracking.models.bearing_only"),
)

#: Class decorator registering a measurement model under a name: ``@register_sensor("sonar")``.
register_sensor = SENSORS.register


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
