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

The built-in sensors are the paper's range-bearing sensor
(:class:`~resilient_tracking.models.range_bearing.RangeBearingSensor`) and a camera's bearing
(:class:`~resilient_tracking.models.bearing_only.BearingOnlySensor`). This module holds what
they share: the noise of one channel (:class:`SensorChannel`), angle wrapping and the second
derivatives of range and bearing.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Annotated, Any, ClassVar

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
    builtins=(
        "resilient_tracking.models.range_bearing",
        "resilient_tracking.models.bearing_only",
    ),
)

#: Class decorator registering a measurement model under a name: ``@register_sensor("sonar")``.
register_sensor = SENSORS.register
