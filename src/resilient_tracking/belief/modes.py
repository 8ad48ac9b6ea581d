"""Per-target motion-mode states of a multiple-model estimate (docs/model.md §4, the IMM).

A target estimated by ``M`` motion models carries, besides its combined Gaussian, one Gaussian per
mode and the mode probabilities. The combined estimate is their moment match (Blom & Bar-Shalom
1988, the IMM's combination step)::

    ŷ = Σ_i μ_i ŷ_i,   P = Σ_i μ_i (P_i + (ŷ_i − ŷ)(ŷ_i − ŷ)ᵀ).

:meth:`ModeStates.reseated` moves a mixture so that its moment match becomes a given Gaussian
(what covariance intersection between leagues and a covariance repair need) by the affine map that
carries one Gaussian onto the other with the least displacement (the Gaussian optimal-transport
map): mode offsets and spreads keep their shape relative to the combined estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]

STATE_DIM = 4


@dataclass
class ModeStates:
    """Mode probabilities ``(N, M)``, means ``(N, M, 4)`` and covariances ``(N, M, 4, 4)`` of
    ``N`` targets under ``M`` motion modes."""

    probabilities: FloatArray
    means: FloatArray
    covs: FloatArray

    def __post_init__(self) -> None:
        self.probabilities = np.asarray(self.probabilities, dtype=float)
        self.means = np.asarray(self.means, dtype=float)
        self.covs = np.asarray(self.covs, dtype=float)
        if self.probabilities.ndim != 2:
            raise ValueError(
                f"ModeStates.probabilities must have shape (N, M), got {self.probabilities.shape}"
            )
        n, m = self.probabilities.shape
        if self.means.shape != (n, m, STATE_DIM):
            raise ValueError(
                f"ModeStates.means must have shape ({n}, {m}, 4), got {self.means.shape}"
            )
        if self.covs.shape != (n, m, STATE_DIM, STATE_DIM):
            raise ValueError(
                f"ModeStates.covs must have shape ({n}, {m}, 4, 4), got {self.covs.shape}"
            )

    @property
    def n_modes(self) -> int:
        """Number of modes ``M``."""
        return int(self.probabilities.shape[1])

    def copy(self) -> ModeStates:
        """A deep copy (arrays are not shared)."""
        return ModeStates(self.probabilities.copy(), self.means.copy(), self.covs.copy())

    def combined(self) -> tuple[FloatArray, FloatArray]:
        """The moment-matched mean ``(N, 4)`` and covariance ``(N, 4, 4)``."""
        return moment_match(self.probabilities, self.means, self.covs)

    @classmethod
    def seated(cls, mean: FloatArray, cov: FloatArray, probabilities: FloatArray) -> ModeStates:
        """Every mode at the Gaussian ``(mean, cov)``, with the ``(M,)`` probabilities for every
        target (or ``(N, M)`` per target)."""
        mean = np.asarray(mean, dtype=float)
        cov = np.asarray(cov, dtype=float)
        n = mean.shape[0]
        p = np.asarray(probabilities, dtype=float)
        p = np.broadcast_to(p, (n, p.shape[-1])).copy()
        m = p.shape[1]
        return cls(
            p,
            np.repeat(mean[:, None, :], m, axis=1),
            np.repeat(cov[:, None, :, :], m, axis=1),
        )

    def reseated(self, mean: FloatArray, cov: FloatArray) -> ModeStates:
        """The mixture moved so that its moment match is ``(mean, cov)``, probabilities kept.

        With ``(ȳ, P̄)`` the current moment match, every mode is mapped by ``x ↦ ŷ + T (x − ȳ)``,
        ``T = P̄^{-1/2} (P̄^{1/2} P P̄^{1/2})^{1/2} P̄^{-1/2}`` (symmetric, ``T P̄ T = P``): means
        ``ŷ + T (ŷ_i − ȳ)``, covariances ``T P_i T``. The moment match of the result is exactly
        ``(ŷ, P)``."""
        mean = np.asarray(mean, dtype=float)
        cov = np.asarray(cov, dtype=float)
        old_mean, old_cov = self.combined()
        t = transport_map(old_cov, cov)
        offsets = np.einsum("nab,nmb->nma", t, self.means - old_mean[:, None, :])
        covs = np.einsum("nab,nmbc,ndc->nmad", t, self.covs, t)
        return ModeStates(self.probabilities.copy(), mean[:, None, :] + offsets, symmetrize(covs))


def moment_match(
    weights: FloatArray, means: FloatArray, covs: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Moment match of Gaussian mixtures over the second-to-last axis of ``means``: weights
    ``(..., M)`` (summing to one), means ``(..., M, 4)``, covariances ``(..., M, 4, 4)``."""
    mean = np.einsum("...m,...ma->...a", weights, means)
    d = means - mean[..., None, :]
    cov = np.einsum("...m,...mab->...ab", weights, covs) + np.einsum(
        "...m,...ma,...mb->...ab", weights, d, d
    )
    return mean, symmetrize(cov)


def pooled(a: ModeStates, b: ModeStates, weight_a: FloatArray) -> ModeStates:
    """The linear pool of two mixtures of the same targets, ``λ`` (``(N,)``) on ``a``:
    probabilities ``λ μ_a + (1 − λ) μ_b``, each mode the moment match of its two versions
    weighted ``λ μ_a,i`` and ``(1 − λ) μ_b,i``. ``λ = 1`` gives ``a``, ``λ = 0`` gives ``b``."""
    if a.probabilities.shape != b.probabilities.shape:
        raise ValueError(
            f"cannot pool mode states of shapes {a.probabilities.shape} and {b.probabilities.shape}"
        )
    lam = np.asarray(weight_a, dtype=float)[:, None]
    wa = lam * a.probabilities
    wb = (1.0 - lam) * b.probabilities
    total = wa + wb
    safe = np.where(total > 0, total, 1.0)
    # both versions of a mode unweighted (probability 0 in both): keep them equally
    share_a = np.where(total > 0, wa / safe, 0.5)
    weights = np.stack([share_a, 1.0 - share_a], axis=-1)  # (N, M, 2)
    means = np.stack([a.means, b.means], axis=2)  # (N, M, 2, 4)
    covs = np.stack([a.covs, b.covs], axis=2)
    mode_means, mode_covs = moment_match(weights, means, covs)
    out = ModeStates(total / total.sum(axis=1, keepdims=True), mode_means, mode_covs)
    ends = (lam[:, 0] == 1.0, lam[:, 0] == 0.0)
    for end, src in zip(ends, (a, b), strict=True):  # exact copies where CI picked one side
        out.probabilities[end] = src.probabilities[end]
        out.means[end] = src.means[end]
        out.covs[end] = src.covs[end]
    return out


def transport_map(source: FloatArray, target: FloatArray) -> FloatArray:
    """Symmetric ``T`` with ``T S T = P`` for SPD stacks ``S`` (source) and ``P`` (target),
    ``(N, 4, 4)``: ``S^{-1/2} (S^{1/2} P S^{1/2})^{1/2} S^{-1/2}``."""
    w, v = np.linalg.eigh(symmetrize(source))
    w = np.maximum(w, np.finfo(float).tiny)
    root = np.einsum("nij,nj,nkj->nik", v, np.sqrt(w), v)
    inv_root = np.einsum("nij,nj,nkj->nik", v, 1.0 / np.sqrt(w), v)
    middle = symmetrize(root @ target @ root)
    w2, v2 = np.linalg.eigh(middle)
    middle_root = np.einsum("nij,nj,nkj->nik", v2, np.sqrt(np.maximum(w2, 0.0)), v2)
    return symmetrize(inv_root @ middle_root @ inv_root)


def symmetrize(cov: FloatArray) -> FloatArray:
    """``(C + Cᵀ) / 2`` over the last two axes."""
    return np.asarray(0.5 * (cov + np.swapaxes(cov, -1, -2)), dtype=float)
