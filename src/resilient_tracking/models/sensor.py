"""Range-bearing sensor with distance-dependent noise (docs/model.md §1, paper eq. 2).

Each sensor has inverse variance ``R⁻¹(d) = peak · exp(−shape · d)``, so the noise variance is
``R(d) = exp(shape · d) / peak``; noise is drawn with that variance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

#: Distances below this are treated as this (the bearing is undefined at zero range).
MIN_RANGE = 1e-3
#: Cap on ``shape · d`` in the noise model: ``exp(600)`` keeps variances finite, far from overflow.
MAX_EXPONENT = 600.0


def wrap_angle(a: FloatArray | float) -> FloatArray | float:
    """Wrap angles to [−π, π)."""
    return (np.asarray(a) + np.pi) % (2.0 * np.pi) - np.pi


@dataclass(frozen=True)
class RangeBearingSensor:
    """Range and bearing to a point target; parameters per sensor channel."""

    range_peak: float = 15.0
    range_shape: float = 0.2
    bearing_peak: float = 15.0
    bearing_shape: float = 0.2
    max_range: float | None = None

    def predict(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """Noise-free measurement ``[‖p − x‖, atan2(Δy, Δx)]``; arrays broadcast over rows."""
        delta = np.asarray(target, dtype=float) - np.asarray(robot, dtype=float)
        rng = np.hypot(delta[..., 0], delta[..., 1])
        bearing = np.arctan2(delta[..., 1], delta[..., 0])
        return np.stack([rng, bearing], axis=-1)

    def noise_variance(self, distance: FloatArray | float) -> FloatArray:
        """Per-channel variance ``[R_range(d), R_bearing(d)]``."""
        d = np.asarray(distance, dtype=float)
        # capped exponent: far beyond the sensor's reach the variance is huge but finite
        return np.stack(
            [
                np.exp(np.minimum(self.range_shape * d, MAX_EXPONENT)) / self.range_peak,
                np.exp(np.minimum(self.bearing_shape * d, MAX_EXPONENT)) / self.bearing_peak,
            ],
            axis=-1,
        )

    def jacobian(self, robot: FloatArray, target: FloatArray) -> FloatArray:
        """Jacobian of the measurement with respect to the target position (2×2)."""
        dx, dy = np.asarray(target, dtype=float) - np.asarray(robot, dtype=float)
        d2 = max(dx * dx + dy * dy, MIN_RANGE**2)
        d = np.sqrt(d2)
        return np.array([[dx / d, dy / d], [-dy / d2, dx / d2]])

    def in_range(self, distance: FloatArray | float) -> NDArray[np.bool_]:
        """Whether a target at this distance is measured at all."""
        d = np.asarray(distance, dtype=float)
        if self.max_range is None:
            return np.ones_like(d, dtype=bool)
        return d <= self.max_range

    def sample(self, robot: FloatArray, target: FloatArray, rng: np.random.Generator) -> FloatArray:
        """A noisy measurement, noise drawn with variance ``R(d)`` (bearing wrapped)."""
        clean = self.predict(robot, target)
        std = np.sqrt(self.noise_variance(clean[..., 0]))
        z = clean + std * rng.standard_normal(clean.shape)
        z[..., 1] = wrap_angle(z[..., 1])
        return z
