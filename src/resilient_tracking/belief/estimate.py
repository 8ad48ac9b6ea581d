"""Per-target Gaussian estimates held by a league (docs/model.md §4).

Targets are estimated independently, so the joint covariance is block diagonal and stored as one
4×4 block per target; state per target ``[px, py, vx, vy]``. A multiple-model estimator (the IMM
of :mod:`~resilient_tracking.belief.imm`) also keeps each target's per-mode states in ``modes``;
``mean`` and ``cov`` are then their moment match, what the rest of the team reads.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from resilient_tracking.belief.modes import ModeStates

FloatArray = NDArray[np.float64]

STATE_DIM = 4


@dataclass
class TargetEstimate:
    """Means ``(N, 4)`` and covariances ``(N, 4, 4)`` of ``N`` independent targets; ``modes``:
    the per-mode states behind them of a multiple-model estimator (``None`` for a single model)."""

    mean: FloatArray
    cov: FloatArray
    modes: ModeStates | None = None

    def __post_init__(self) -> None:
        self.mean = np.asarray(self.mean, dtype=float)
        self.cov = np.asarray(self.cov, dtype=float)
        if self.mean.ndim != 2 or self.mean.shape[1] != STATE_DIM:
            raise ValueError(f"TargetEstimate.mean must have shape (N, 4), got {self.mean.shape}")
        n = self.mean.shape[0]
        if self.cov.shape != (n, STATE_DIM, STATE_DIM):
            raise ValueError(
                f"TargetEstimate.cov must have shape ({n}, 4, 4), got {self.cov.shape}"
            )
        if self.modes is not None and self.modes.probabilities.shape[0] != n:
            raise ValueError(
                f"TargetEstimate.modes must describe {n} targets, "
                f"got {self.modes.probabilities.shape[0]}"
            )

    @classmethod
    def trusted(cls, mean: FloatArray, cov: FloatArray) -> TargetEstimate:
        """A single-model estimate from float64 arrays already of the right shapes (an
        estimator's own results, every tick): made without checking them again."""
        est = cls.__new__(cls)
        est.mean, est.cov, est.modes = mean, cov, None
        return est

    def copy(self) -> TargetEstimate:
        """A deep copy (arrays are not shared)."""
        modes = None if self.modes is None else self.modes.copy()
        return TargetEstimate(self.mean.copy(), self.cov.copy(), modes)

    @property
    def n_targets(self) -> int:
        """Number of targets ``N``."""
        return int(self.mean.shape[0])

    def position_traces(self) -> FloatArray:
        """Per-target ``tr P_j[:2, :2]``, shape ``(N,)``."""
        return np.asarray(self.cov[:, 0, 0] + self.cov[:, 1, 1], dtype=float)

    def position_trace(self) -> float:
        """``Σ_j tr P_j[:2, :2]`` — the tracking-error measure of the paper."""
        return float(np.add.reduce(self.position_traces()))  # (ndarray.sum's, sans wrapper)

    @classmethod
    def initial(cls, means: FloatArray, position_std: float, velocity_std: float) -> TargetEstimate:
        """Estimate with the given means and diagonal covariance
        ``diag(σ_p², σ_p², σ_v², σ_v²)`` for every target."""
        if not (np.isfinite(position_std) and position_std > 0):
            raise ValueError(f"position_std must be positive and finite, got {position_std}")
        if not (np.isfinite(velocity_std) and velocity_std > 0):
            raise ValueError(f"velocity_std must be positive and finite, got {velocity_std}")
        m = np.array(means, dtype=float, copy=True)
        if m.ndim != 2 or m.shape[1] != STATE_DIM:
            raise ValueError(f"means must have shape (N, 4), got {m.shape}")
        if not np.all(np.isfinite(m)):
            raise ValueError("means must be finite")
        block = np.diag([position_std**2, position_std**2, velocity_std**2, velocity_std**2])
        cov = np.repeat(block[None, :, :], m.shape[0], axis=0)
        return cls(m, cov)
