"""Extended Kalman filter over independent targets, measured through the team's sensor model
(docs/model.md §4; the paper's is range-bearing).

Prediction (paper, EKF prediction eq.): ``ŷ⁺ = A ŷ``, ``P⁺ = A P Aᵀ + Q`` per target.

Update (paper eqs. ``state_update`` / ``cov_inv_update``): all robots' measurements of a target are
stacked and linearised at the *predicted* target position, giving

    P⁻¹_{t+1|t+1} = P⁻¹_{t+1|t} + Σ_k H_kᵀ R_k⁻¹ H_k,
    ŷ_{t+1|t+1}   = ŷ_{t+1|t} + K z̃,   K z̃ = P_{t+1|t+1} Σ_k H_kᵀ R_k⁻¹ z̃_k,

with ``H_k`` the D×4 Jacobian (D = the sensor's ``DIM``; position columns from the sensor
model's ``jacobian``, zero velocity columns), ``R_k = diag(R(d̂_k))`` from the *predicted*
distance (the filter never sees the true one) and the innovations of the sensor's angle channels
(``ANGLES``: the bearing) wrapped to [−π, π). The information sum is evaluated in the equivalent
gain form (``P`` is never inverted) and the covariance in Joseph form, so it stays
symmetric positive definite. Everything is vectorised over robots × targets.

Two options (off by default: the paper's EKF) serve a robot close to a target, where the
measurement is far from linear across the prior's spread (a bearing's Hessian grows as 1/d²):

* ``second_order``: each channel's variance carries the second-order term of the measurement's
  Taylor expansion, ``R_c + ½ tr(H″_c P_pp H″_c P_pp)`` (the second-order EKF's innovation
  covariance, Bar-Shalom, Li & Kirubarajan 2001 §10.3), so a bearing taken within the prior's
  spread counts for little;
* ``iterations`` > 1: the iterated EKF (Gauss-Newton on the posterior, Bell & Cathey 1993):
  relinearise at the last update's position ``p_i`` and update the *prior* again with
  innovations ``z − h(p_i) − H_i (p̂ − p_i)``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.numpy_twins import all_finite
from resilient_tracking.models.sensor import MeasurementModel, wrap_angle_in_place

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class EkfUpdate:
    """Result of one update with consistency diagnostics.

    ``nis[k, j]``: normalized innovation squared ``ν_kjᵀ S_kj⁻¹ ν_kj`` of robot ``k``'s measurement
    of target ``j`` alone against the prior (χ²(D) if consistent, D the sensor's ``DIM``), NaN
    where not measured. ``joint_nis[j]``: NIS of all measurements of target ``j`` stacked
    (χ²(``dof[j]``) if consistent), NaN where ``dof[j] == 0``. ``dof[j] = D ·`` number of robots
    that measured ``j``.
    """

    estimate: TargetEstimate
    nis: FloatArray
    joint_nis: FloatArray
    dof: NDArray[np.int64]


class ExtendedKalmanFilter:
    """EKF for ``N`` independent NCV targets observed by ``K`` robots through ``sensor``
    (its measurement, Jacobian and noise; the paper's is range-bearing)."""

    #: its update takes ``noise_scale`` (:class:`~.estimator.Estimator`)
    scales_noise = True

    def __init__(
        self,
        model: NearlyConstantVelocity,
        sensor: MeasurementModel,
        iterations: int = 1,
        second_order: bool = False,
    ) -> None:
        if iterations < 1:
            raise ValueError(f"an EKF update needs at least one iteration, got {iterations}")
        self.model = model
        self.sensor = sensor
        #: linearisations per update: 1 is the paper's EKF, more the iterated EKF
        self.iterations = int(iterations)
        #: whether each channel's noise variance carries its second-order term
        self.second_order = bool(second_order)
        self._a = model.transition
        self._at = self._a.T  # (made once: the same view each predict)
        self._q = model.process_noise

    def with_update(self, iterations: int, second_order: bool) -> ExtendedKalmanFilter:
        """The same filter with another measurement update: ``iterations`` linearisations, and
        the second-order noise term or not."""
        return ExtendedKalmanFilter(self.model, self.sensor, iterations, second_order)

    def predict(self, est: TargetEstimate) -> TargetEstimate:
        """Prediction: ``ŷ_{t+1|t} = A ŷ_t``, ``P_{t+1|t} = A P_t Aᵀ + Q`` (new object)."""
        a = self._a
        mean = est.mean @ self._at
        cov = np.einsum("ij,njk,lk->nil", a, est.cov, a)
        np.add(cov, self._q, out=cov)  # (in place: the same sum, no second array)
        return TargetEstimate.trusted(mean, _symmetrize(cov))

    def update(
        self,
        est: TargetEstimate,
        robot_positions: FloatArray,
        measurements: FloatArray,
        nis_out: list[float] | None = None,
        noise_scale: FloatArray | None = None,
    ) -> TargetEstimate:
        """Measurement update (eqs. ``state_update``, ``cov_inv_update``); returns a new object.

        ``robot_positions`` ``(K, 2)``, ``measurements`` ``(K, N, D)`` (D the sensor's ``DIM``;
        ``[range, bearing]`` for the paper's sensor), NaN where robot ``k`` did not measure target
        ``j`` (skipped). If ``nis_out`` is given, the
        per-(robot, target) NIS of the measurements used are appended to it, robot-major.
        ``noise_scale`` ``(K,)``: robot ``k``'s noise variance is ``noise_scale[k] · R(d̂)`` (a
        sensor found degraded, :mod:`~resilient_tracking.belief.degradation_watch`); ``None``:
        the nominal ``R``.
        """
        if nis_out is None:  # the estimate only: no diagnostics to compute
            return self._linearised(est, robot_positions, measurements, noise_scale)[0]
        res = self.update_detailed(est, robot_positions, measurements, noise_scale)
        nis_out.extend(res.nis[np.isfinite(res.nis)].tolist())
        return res.estimate

    def update_with_nis(
        self, est: TargetEstimate, robot_positions: FloatArray, measurements: FloatArray
    ) -> tuple[TargetEstimate, FloatArray]:
        """Like :meth:`update`, also returning the ``(K, N)`` per-measurement NIS (NaN if none)."""
        res = self.update_detailed(est, robot_positions, measurements)
        return res.estimate, res.nis

    def update_with_likelihood(
        self,
        est: TargetEstimate,
        robot_positions: FloatArray,
        measurements: FloatArray,
        noise_scale: FloatArray | None = None,
    ) -> tuple[TargetEstimate, FloatArray]:
        """Like :meth:`update`, also returning per target the log-likelihood
        ``log N(z̃; 0, S)`` of its stacked measurements against the prior (0 where none), what a
        multiple-model filter weighs its modes by.

        ``z̃ᵀ S⁻¹ z̃`` is the stacked NIS (Woodbury, as in :meth:`update_detailed`) and
        ``log det S = Σ_k log det R_k + log det(I + J P_pp)`` (matrix determinant lemma), with
        ``J`` the position information of the update.
        """
        estimate, lin = self._linearised(est, robot_positions, measurements, noise_scale)
        hjac, var, valid, innov, rinv, b, info = lin
        _, logdet_m = np.linalg.slogdet(_EYE2 + info @ est.cov[:, :2, :2])
        logdet_r = np.log(np.where(valid[..., None], var, 1.0)).sum(axis=(0, 2))
        quad = np.einsum("kna,kna,kna->n", innov, rinv, innov) - np.einsum(
            "ni,nij,nj->n", b, estimate.cov[:, :2, :2], b
        )
        dof = self.sensor.DIM * valid.sum(axis=0)
        loglik = -0.5 * (quad + logdet_r + logdet_m + dof * np.log(2.0 * np.pi))
        return estimate, np.where(dof > 0, loglik, 0.0)

    def _linearised(
        self,
        est: TargetEstimate,
        robot_positions: FloatArray,
        measurements: FloatArray,
        noise_scale: FloatArray | None = None,
    ) -> tuple[TargetEstimate, _Linearisation]:
        """The updated estimate, and what the diagnostics of :meth:`update_detailed` need: at
        the predicted positions, then (iterated EKF) at each update's result."""
        at = None
        for _ in range(self.iterations):
            lin, gain = self._linearised_at(est, robot_positions, measurements, at, noise_scale)
            mean = est.mean + (gain @ lin.b[..., None])[..., 0]
            at = mean[:, :2]  # (only the last linearisation's covariance is formed)
        return TargetEstimate.trusted(mean, _joseph(est.cov, gain, lin.info)), lin

    def _linearised_at(
        self,
        est: TargetEstimate,
        robot_positions: FloatArray,
        measurements: FloatArray,
        at: FloatArray | None,
        noise_scale: FloatArray | None = None,
    ) -> tuple[_Linearisation, FloatArray]:
        """The measurements linearised at the target positions ``at`` ``(N, 2)`` (``None``: at
        the predicted ones, the paper's EKF), robot ``k``'s noise variance scaled by
        ``noise_scale[k]`` (``None``: nominal), and the update's gain ``F`` ``(N, 4, 2)``: the
        updated mean is ``ŷ + F b``."""
        n = est.mean.shape[0]  # (the number of targets)
        robots = np.asarray(robot_positions, dtype=float).reshape(-1, 2)
        k = robots.shape[0]
        z = np.asarray(measurements, dtype=float)
        sensor = self.sensor
        if z.shape != (k, n, sensor.DIM):
            raise ValueError(
                f"measurements must have shape ({k}, {n}, {sensor.DIM}), got {z.shape}"
            )
        if not all_finite(robots):
            raise ValueError("robot_positions must be finite")

        mean, cov = est.mean, est.cov
        pos = mean[:, :2] if at is None else at
        seen_from, seen = robots[:, None, :], pos[None, :, :]
        # h (K, N, D), its Jacobian (K, N, D, 2), R(d̂) at the predicted distance (K, N, D)
        h, hjac, var = sensor.linearise(seen_from, seen)
        if noise_scale is not None:  # a degraded sensor's R, scaled (docs/model.md §6.4)
            var = var * np.asarray(noise_scale, dtype=float).reshape(k, 1, 1)
        if self.second_order:  # + ½ tr(H″_c P H″_c P) per channel c (second-order EKF)
            hess = sensor.hessian(seen_from, seen)  # (K, N, D, 2, 2)
            hp = hess @ cov[None, :, None, :2, :2]
            var = var + 0.5 * np.einsum("kncab,kncba->knc", hp, hp)

        # every robot measured every target: nothing to mask
        measured_all = all_finite(z)
        valid = _all_true(k, n) if measured_all else np.isfinite(z).all(axis=-1)  # (K, N)
        innov = z - h
        if at is not None:  # iterated EKF: z − h(p_i) − H_i (p̂ − p_i)
            innov = innov - np.einsum("kncj,nj->knc", hjac, mean[:, :2] - at)
        for channel in sensor.ANGLES:
            wrap_angle_in_place(innov[..., channel])
        if measured_all:
            rinv = np.divide(_ONE, var)
        else:
            innov = np.where(valid[..., None], innov, 0.0)
            rinv = np.where(valid[..., None], 1.0 / var, 0.0)

        # Information contributed to the position block: J = Σ_k Hᵀ R⁻¹ H, b = Σ_k Hᵀ R⁻¹ z̃.
        info = np.einsum("knai,kna,knaj->nij", hjac, rinv, hjac)
        b = np.einsum("knai,kna,kna->ni", hjac, rinv, innov)

        # With W = (I + J P_pp)⁻¹ (always invertible, J may be singular):
        #   (P⁻¹ + Eᵀ J E)⁻¹ Eᵀ = P Eᵀ W =: F,  ŷ⁺ = ŷ + F b,  stacked gain K with K H = F J E.
        m = _EYE2 + info @ cov[:, :2, :2]
        f = np.linalg.solve(m.swapaxes(1, 2), cov[:, :2, :]).swapaxes(1, 2)  # (N, 4, 2)
        return _Linearisation(hjac, var, valid, innov, rinv, b, info), f

    def update_detailed(
        self,
        est: TargetEstimate,
        robot_positions: FloatArray,
        measurements: FloatArray,
        noise_scale: FloatArray | None = None,
    ) -> EkfUpdate:
        """Measurement update with all diagnostics (see :class:`EkfUpdate`)."""
        estimate, lin = self._linearised(est, robot_positions, measurements, noise_scale)
        cov, new_cov = est.cov, estimate.cov
        hjac, var, valid, innov, rinv, b, _ = lin

        # Per-measurement NIS against the prior: S = H P_pp Hᵀ + R.
        s = hjac @ cov[None, :, :2, :2] @ np.swapaxes(hjac, -1, -2)
        for channel in range(self.sensor.DIM):
            s[..., channel, channel] += var[..., channel]
        nis = np.einsum("kna,kna->kn", innov, np.linalg.solve(s, innov[..., None])[..., 0])
        nis = np.where(valid, nis, np.nan)

        # Stacked NIS via Woodbury: z̃ᵀ S⁻¹ z̃ = Σ_k z̃_kᵀ R_k⁻¹ z̃_k − bᵀ P⁺_pp b.
        dof = self.sensor.DIM * valid.sum(axis=0).astype(np.int64)
        quad = np.einsum("kna,kna,kna->n", innov, rinv, innov)
        joint = quad - np.einsum("ni,nij,nj->n", b, new_cov[:, :2, :2], b)
        joint = np.where(dof > 0, joint, np.nan)

        return EkfUpdate(estimate, nis, joint, dof)


class _Linearisation(NamedTuple):
    """The linearised measurements of one update (for its diagnostics)."""

    hjac: FloatArray
    var: FloatArray
    valid: NDArray[np.bool_]
    innov: FloatArray
    rinv: FloatArray
    b: FloatArray
    #: the position information ``J = Σ_k Hᵀ R⁻¹ H`` ``(N, 2, 2)``
    info: FloatArray


_EYE2, _EYE4 = np.eye(2), np.eye(4)
_EYE2.flags.writeable = _EYE4.flags.writeable = False
#: 1 and ½ as 0-d float64 arrays (faster than Python floats in NumPy operations, same numbers)
_ONE, _HALF = np.array(1.0), np.array(0.5)


@functools.cache
def _eye4_stack(n: int) -> FloatArray:
    """``n`` 4×4 identities (read-only, shared: copied before use)."""
    eyes = np.repeat(_EYE4[None], n, axis=0)
    eyes.flags.writeable = False
    return eyes


@functools.cache
def _all_true(k: int, n: int) -> NDArray[np.bool_]:
    """``(k, n)`` trues (read-only, shared): every robot measured every target."""
    valid = np.ones((k, n), dtype=bool)
    valid.flags.writeable = False
    return valid


def _joseph(cov: FloatArray, f: FloatArray, info: FloatArray) -> FloatArray:
    """The updated covariance in Joseph form ``(I − KH) P (I − KH)ᵀ + K R Kᵀ`` from the gain
    ``F`` and position information ``J`` of an update: ``KH = [F J, 0]``
    and ``K R Kᵀ = F J Fᵀ``, a sum of congruences, so it stays positive definite numerically."""
    f_info = f @ info
    # I − KH: the identity's last two columns as they are (1 − 0 and 0 − 0 are exact), the first
    # two I − F J
    i_kh = _eye4_stack(cov.shape[0]).copy()
    np.subtract(_EYE4[:, :2], f_info, out=i_kh[:, :, :2])
    joseph = i_kh @ cov @ i_kh.swapaxes(1, 2) + f_info @ f.swapaxes(1, 2)
    return _symmetrize(joseph)


def _symmetrize(cov: FloatArray) -> FloatArray:
    """``(P + Pᵀ)/2`` (halved in place in the sum's own array)."""
    out = cov + cov.swapaxes(-1, -2)
    return np.multiply(_HALF, out, out=out)
