"""Interacting multiple model (IMM) estimator over independent targets (docs/model.md §4).

``M`` nearly-constant-velocity models that differ in their process noise (a quiet model and a
manoeuvre model, say) run side by side per target, switching by a Markov chain with transition
matrix ``Π`` (``Π_ij``: probability of mode ``j`` next given mode ``i`` now). One cycle is the
standard IMM of Blom & Bar-Shalom (1988); with ``μ_i`` the mode probabilities:

* mixing (in :meth:`predict`): predicted mode probabilities ``c_j = Σ_i Π_ij μ_i``, mixing
  weights ``μ_{i|j} = Π_ij μ_i / c_j``, mixed states ``ŷ⁰_j = Σ_i μ_{i|j} ŷ_i`` and
  ``P⁰_j = Σ_i μ_{i|j} (P_i + (ŷ_i − ŷ⁰_j)(ŷ_i − ŷ⁰_j)ᵀ)``;
* mode-matched prediction: ``ŷ_j = A ŷ⁰_j``, ``P_j = A P⁰_j Aᵀ + Q_j``;
* mode-matched update (in :meth:`update`): every mode through the team's EKF measurement update
  (:class:`~resilient_tracking.belief.ekf.ExtendedKalmanFilter`, stacked over robots), giving the
  likelihood ``Λ_j = N(z̃_j; 0, S_j)`` of the target's measurements under mode ``j``. The
  scenario's IMM updates its modes by the iterated second-order EKF: a manoeuvre mode's wide
  velocity spread turns the first-order update's errors next to a robot (its bearing's linearisation
  fails within the prior's spread) into velocity errors that feed on themselves;
* mode probabilities ``μ_j ∝ Λ_j c_j`` (``c_j`` when the target was not measured);
* combination: the moment match of the modes (:mod:`~resilient_tracking.belief.modes`), the
  estimate's ``mean`` and ``cov`` that the planner, the fusion and the records read.

Everything is vectorised over targets × modes (the modes are stacked as extra targets of one
EKF update). An estimate without mode states (the prior) starts with every mode at its Gaussian
and the initial mode probabilities.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from resilient_tracking.belief.ekf import ExtendedKalmanFilter
from resilient_tracking.belief.estimate import TargetEstimate
from resilient_tracking.belief.modes import ModeStates, symmetrize
from resilient_tracking.models.motion import NearlyConstantVelocity
from resilient_tracking.models.sensor import MeasurementModel

FloatArray = NDArray[np.float64]


class InteractingMultipleModel:
    """IMM over ``models`` (same ``dt``) with Markov ``transition`` ``(M, M)`` (rows sum to one)
    and ``initial`` mode probabilities ``(M,)``, measured through ``sensor``."""

    #: its update takes ``noise_scale`` (:class:`~.estimator.Estimator`)
    scales_noise = True

    def __init__(
        self,
        models: Sequence[NearlyConstantVelocity],
        transition: FloatArray,
        initial: FloatArray,
        sensor: MeasurementModel,
        iterations: int = 1,
        second_order: bool = False,
    ) -> None:
        m = len(models)
        if m < 1:
            raise ValueError("an IMM needs at least one model")
        if len({model.dt for model in models}) != 1:
            raise ValueError("the models of an IMM must share one time step")
        pi = np.array(transition, dtype=float)
        mu0 = np.array(initial, dtype=float)
        if pi.shape != (m, m) or mu0.shape != (m,):
            raise ValueError(
                f"{m} models need a ({m}, {m}) transition matrix and {m} initial probabilities, "
                f"got {pi.shape} and {mu0.shape}"
            )
        if (pi < 0).any() or not np.allclose(pi.sum(axis=1), 1.0, rtol=0, atol=1e-12):
            raise ValueError("the transition matrix must be non-negative with rows summing to 1")
        if (mu0 < 0).any() or not np.isclose(mu0.sum(), 1.0, rtol=0, atol=1e-12):
            raise ValueError("the initial mode probabilities must be non-negative, summing to 1")
        self.models = tuple(models)
        self.transition = pi
        self.initial = mu0
        self.sensor = sensor
        self._a = models[0].transition
        self._q = np.stack([model.process_noise for model in models])  # (M, 4, 4)
        # The measurement update does not involve the motion model: one EKF serves every mode.
        self._ekf = ExtendedKalmanFilter(models[0], sensor, iterations, second_order)

    @classmethod
    def quiet_and_manoeuvre(
        cls,
        dt: float,
        accel_std: float,
        manoeuvre_accel_std: float,
        switch_probability: float,
        sensor: MeasurementModel,
        iterations: int = 1,
        second_order: bool = False,
    ) -> InteractingMultipleModel:
        """Two NCV modes, quiet (``accel_std``) and manoeuvring (``manoeuvre_accel_std``), each
        left with ``switch_probability`` per step; both equally likely at the start (the chain's
        stationary distribution). ``iterations`` and ``second_order``: the modes' EKF update
        (:class:`~resilient_tracking.belief.ekf.ExtendedKalmanFilter`)."""
        p = switch_probability
        return cls(
            [
                NearlyConstantVelocity(dt, accel_std),
                NearlyConstantVelocity(dt, manoeuvre_accel_std),
            ],
            np.array([[1.0 - p, p], [p, 1.0 - p]]),
            np.array([0.5, 0.5]),
            sensor,
            iterations,
            second_order,
        )

    @classmethod
    def noise_levels(
        cls,
        dt: float,
        accel_stds: Sequence[float],
        switch_probability: float,
        sensor: MeasurementModel,
        iterations: int = 1,
        second_order: bool = False,
    ) -> InteractingMultipleModel:
        """NCV modes on a ladder of process noises ``accel_stds`` (sorted), each moving to each
        neighbouring level with ``switch_probability`` per step (a birth–death chain), every
        level equally likely at the start: the mode probabilities learn a target's noise level
        from its measurements, and follow it when it changes (adaptive process noise)."""
        levels = sorted(float(s) for s in accel_stds)
        m = len(levels)
        transition = np.zeros((m, m))
        for i in range(m):
            for j in (i - 1, i + 1):
                if 0 <= j < m:
                    transition[i, j] = switch_probability
            transition[i, i] = 1.0 - transition[i].sum()
        return cls(
            [NearlyConstantVelocity(dt, s) for s in levels],
            transition,
            np.full(m, 1.0 / m),
            sensor,
            iterations,
            second_order,
        )

    @property
    def n_modes(self) -> int:
        """Number of models ``M``."""
        return len(self.models)

    def modes_of(self, est: TargetEstimate) -> ModeStates:
        """``est``'s mode states, or every mode at its Gaussian with the initial probabilities."""
        if est.modes is None:
            return ModeStates.seated(est.mean, est.cov, self.initial)
        if est.modes.n_modes != self.n_modes:
            raise ValueError(
                f"the estimate has {est.modes.n_modes} modes, the IMM {self.n_modes} models"
            )
        return est.modes

    def predict(self, est: TargetEstimate) -> TargetEstimate:
        """Mixing and mode-matched prediction; the combined prediction (new object)."""
        modes = self.modes_of(est)
        mu, means, covs = modes.probabilities, modes.means, modes.covs
        c = mu @ self.transition  # (N, M): c_j = Σ_i Π_ij μ_i
        # mixing weights μ_{i|j}; a mode nothing can reach (c_j = 0) mixes by μ_i
        joint = mu[:, :, None] * self.transition[None, :, :]
        weights = np.where(
            c[:, None, :] > 0, joint / np.where(c > 0, c, 1.0)[:, None, :], mu[:, :, None]
        )
        mixed = np.einsum("nij,nia->nja", weights, means)
        d = means[:, :, None, :] - mixed[:, None, :, :]  # ŷ_i − ŷ⁰_j, (N, i, j, 4)
        mixed_cov = np.einsum("nij,niab->njab", weights, covs) + np.einsum(
            "nij,nija,nijb->njab", weights, d, d
        )
        a = self._a
        pred_means = mixed @ a.T
        pred_covs = symmetrize(np.einsum("ab,nmbc,dc->nmad", a, mixed_cov, a) + self._q)
        return _combined(ModeStates(c, pred_means, pred_covs))

    def with_update(self, iterations: int, second_order: bool) -> InteractingMultipleModel:
        """This IMM: its modes' updates are its own (set at construction), so a league with a
        degraded sensor updates as any other (:class:`~.estimator.Estimator`)."""
        return self

    def update(
        self,
        est: TargetEstimate,
        robot_positions: FloatArray,
        measurements: FloatArray,
        noise_scale: FloatArray | None = None,
    ) -> TargetEstimate:
        """Mode-matched EKF updates, mode probabilities, combination (new object); robot
        ``k``'s noise variance scaled by ``noise_scale[k]`` (``None``: nominal)."""
        return self.update_with_likelihood(est, robot_positions, measurements, noise_scale)[0]

    def update_with_likelihood(
        self,
        est: TargetEstimate,
        robot_positions: FloatArray,
        measurements: FloatArray,
        noise_scale: FloatArray | None = None,
    ) -> tuple[TargetEstimate, FloatArray]:
        """Like :meth:`update`, also returning the ``(N, M)`` log-likelihoods ``log Λ_j``."""
        modes = self.modes_of(est)
        n, m = modes.probabilities.shape
        z = np.asarray(measurements, dtype=float)
        if z.ndim != 3 or z.shape[1] != n:
            raise ValueError(
                f"measurements must have shape (K, {n}, {self.sensor.DIM}), got {z.shape}"
            )
        flat = TargetEstimate(modes.means.reshape(n * m, 4), modes.covs.reshape(n * m, 4, 4))
        updated, loglik = self._ekf.update_with_likelihood(
            flat, robot_positions, np.repeat(z, m, axis=1), noise_scale
        )
        loglik = loglik.reshape(n, m)
        with np.errstate(divide="ignore"):
            log_w = np.log(modes.probabilities) + loglik
        log_w -= log_w.max(axis=1, keepdims=True)
        w = np.exp(log_w)
        mu = w / w.sum(axis=1, keepdims=True)
        states = ModeStates(mu, updated.mean.reshape(n, m, 4), updated.cov.reshape(n, m, 4, 4))
        return _combined(states), loglik


def _combined(modes: ModeStates) -> TargetEstimate:
    mean, cov = modes.combined()
    return TargetEstimate(mean, cov, modes)
