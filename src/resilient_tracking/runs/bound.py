"""The posterior Cramér–Rao bound of the targets' positions along a run (docs/model.md §8).

No estimator using the robots' measurements can have a smaller mean squared position error
than the bound. It is computed on truth's side with Tichavský's information recursion
(Tichavský, Muravchik and Nehorai 1998): per target, with the motion ``x' = F x + w``,
``w ~ N(0, Q)``,

    J₀ = P₀⁻¹ + Iₘ(0),        J_k = (Q + F J_{k−1}⁻¹ Fᵀ)⁻¹ + Iₘ(k),

where ``P₀`` is the team's prior covariance and ``Iₘ(k)`` the Fisher information of the
measurements taken at step ``k``: those the robots actually had (sensors down, out of range,
dropped: none), from where they actually were, at the targets' true positions, with the noise
they were actually drawn with (a degraded sensor's factor included). A measurement
``z ~ N(h(p), R(p))`` whose noise depends on the distance carries

    Iₘ = Hᵀ R⁻¹ H + ½ Σ_c ∇ln R_c ∇ln R_cᵀ,

the second term being what the noise level itself says of the distance (paper eq. 2 makes it
grow with distance). The bound is a true bound where the targets move by that linear-Gaussian
model: ``ncv`` (its ``accel_std``) and ``constant_velocity`` (``Q = 0``). For targets on
scripted paths (waypoints, circles, evasive or luring targets) no such model holds; the bound
is computed with the estimator's own model there and is only indicative (:attr:`exact`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.sensor import MeasurementModel

#: Target motions whose truth is the linear-Gaussian model the bound assumes.
LINEAR_GAUSSIAN_MOTIONS = ("ncv", "constant_velocity")


def exact_for(motion_types: Sequence[str]) -> bool:
    """Whether targets moving by ``motion_types`` (one per target) all follow the
    linear-Gaussian model the bound assumes, so that it is a true bound."""
    return bool(motion_types) and all(m in LINEAR_GAUSSIAN_MOTIONS for m in motion_types)


#: Relative step of the central differences of ``ln R`` (m per m of position).
_STEP = 1e-6


def _log_noise(sensor: MeasurementModel, robots: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """``ln R`` per channel (K, D) of the measurements of ``targets`` from ``robots`` (K, 2)."""
    clean = sensor.predict(robots, targets)
    return np.log(sensor.noise_variance(sensor.noise_distance(robots, targets, clean)))


def measurement_information(
    sensor: MeasurementModel, robots: np.ndarray, targets: np.ndarray, noise_factor: np.ndarray
) -> np.ndarray:
    """Fisher information (K, 2, 2) about the target position of one measurement each of
    ``targets`` (K, 2) from ``robots`` (K, 2), noise standard deviation scaled by
    ``noise_factor`` (K,): ``Hᵀ R⁻¹ H + ½ Σ_c ∇ln R_c ∇ln R_cᵀ``."""
    jac = sensor.jacobian(robots, targets)  # (K, D, 2)
    clean = sensor.predict(robots, targets)
    var = sensor.noise_variance(sensor.noise_distance(robots, targets, clean))
    var = var * (noise_factor * noise_factor)[:, None]
    info = np.einsum("kda,kd,kdb->kab", jac, 1.0 / var, jac)
    h = _STEP * np.maximum(1.0, np.abs(targets).max(axis=1))[:, None]  # (K, 1)
    grad = np.empty(jac.shape)  # ∂ln R_c/∂p, by central differences (the factor cancels)
    for axis in (0, 1):
        step = np.zeros_like(targets)
        step[:, axis] = h[:, 0]
        up = _log_noise(sensor, robots, targets + step)
        down = _log_noise(sensor, robots, targets - step)
        grad[:, :, axis] = (up - down) / (2.0 * h)
    return np.asarray(info + 0.5 * np.einsum("kda,kdb->kab", grad, grad))


class PositionBound:
    """The bound of one run, a step at a time (:meth:`step`), for every target."""

    def __init__(
        self,
        sensor: MeasurementModel,
        dt: float,
        motions: Sequence[Any],
        filter_accel_std: float,
        initial_position_std: float,
        initial_velocity_std: float,
    ):
        """``motions``: each target's motion spec (``type`` and, for ``ncv``, ``accel_std``);
        ``filter_accel_std``: the estimator's model, used where the truth has none; the prior's
        standard deviations as the team's."""
        self.sensor = sensor
        #: whether every target moves by the linear-Gaussian model (a true bound), or the bound
        #: borrows the estimator's model for some (indicative only)
        self.exact = exact_for([m.type for m in motions])
        self._transition = NearlyConstantVelocity(dt, 0.0).transition
        self._noise = np.array([self._process_noise(m, dt, filter_accel_std) for m in motions])
        prior = np.diag([initial_position_std**2] * 2 + [initial_velocity_std**2] * 2)
        self._info = np.repeat(np.linalg.inv(prior)[None], len(motions), axis=0)
        self._started = False

    @staticmethod
    def _process_noise(motion: Any, dt: float, filter_accel_std: float) -> np.ndarray:
        if motion.type == "constant_velocity":
            return np.zeros((4, 4))
        accel = motion.accel_std if motion.type == "ncv" else filter_accel_std
        return NearlyConstantVelocity(dt, accel).process_noise

    def step(
        self,
        robots: np.ndarray,
        measured: np.ndarray,
        noise_factor: np.ndarray,
        targets: np.ndarray,
    ) -> float:
        """Take in one step, return ``(1/N) Σ_j tr`` of the bound of the target positions.

        ``robots`` (M, 2) where the robots were, ``measured`` (M, N) which robot measured
        which target, ``noise_factor`` (M,) each robot's noise factor, ``targets`` (N, 2) the
        true positions."""
        info = self._info
        if self._started:  # predicted information (Q + F J⁻¹ Fᵀ)⁻¹
            f = self._transition
            info = np.asarray(np.linalg.inv(self._noise + f @ np.linalg.inv(info) @ f.T))
        else:
            info = info.copy()
        self._started = True
        rows, cols = np.nonzero(measured)
        if len(rows):
            gained = measurement_information(
                self.sensor, robots[rows], targets[cols], noise_factor[rows]
            )
            position = np.zeros((len(targets), 2, 2))
            np.add.at(position, cols, gained)
            info[:, :2, :2] += position
        self._info = info
        bound = np.linalg.inv(info)
        return float((bound[:, 0, 0] + bound[:, 1, 1]).mean())
